"""Rooms for the tests: the `tiny` and `studio` presets made by the `neuroom` command and trained
with short step budgets at a fixed seed, once per session."""

from __future__ import annotations

import os
import pathlib
import shutil
import subprocess

import pytest

import neuroom

# Training steps per model: enough for locate to find the camera and objects of the presets.
STEPS = 300


def neuroom_command() -> pathlib.Path:
    """The `neuroom` binary the package is compared with: `$NEUROOM_BIN`, else the one on `PATH`."""
    given = os.environ.get("NEUROOM_BIN") or shutil.which("neuroom")
    if not given:
        pytest.fail("set NEUROOM_BIN to the neuroom binary (cargo build --release -p neuroom-cli)")
    return pathlib.Path(given)


def run_cli(*args: str | os.PathLike[str]) -> subprocess.CompletedProcess[str]:
    """Runs the `neuroom` command; a failure fails the test with its output."""
    done = subprocess.run(
        [str(neuroom_command()), *map(str, args)], capture_output=True, text=True
    )
    if done.returncode != 0:
        pytest.fail(f"neuroom {' '.join(map(str, args))} failed:\n{done.stdout}\n{done.stderr}")
    return done


def synthesized(folder: pathlib.Path, preset: str) -> pathlib.Path:
    room = folder / preset
    run_cli("synth", "--preset", preset, "--out", room, "--seed", "0")
    return room


@pytest.fixture(scope="session")
def tiny_room(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    return synthesized(tmp_path_factory.mktemp("rooms"), "tiny")


@pytest.fixture(scope="session")
def studio_models(tmp_path_factory: pytest.TempPathFactory) -> neuroom.Models:
    room = synthesized(tmp_path_factory.mktemp("rooms"), "studio")
    out = tmp_path_factory.mktemp("models")
    return neuroom.Models.train(room, out, steps=STEPS, seed=0, threads=2)
