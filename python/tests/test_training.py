"""Training from Python: one model at a time into one folder, progress reports, and interruption
(Ctrl-C or a callback that raises) with the checkpoint kept and resumed."""

from __future__ import annotations

import _thread
import io
import pathlib
import threading

import pytest
import tqdm

import neuroom
from conftest import run_cli

# A few steps per model: these tests check bookkeeping, not quality.
STEPS = 20
# The budget of the model interrupted and resumed: long enough to interrupt after a few steps.
RESUMED_STEPS = 300


def test_models_train_one_at_a_time(tiny_room: pathlib.Path, tmp_path: pathlib.Path) -> None:
    first = neuroom.Models.train(tiny_room, tmp_path, steps=STEPS, only=["background"], seed=0)
    assert first.names == ["background"] and not first.complete
    names = neuroom.Room(tiny_room).model_names
    assert names[0] == "background" and len(names) >= 2
    reports: list[tuple[str, int, int]] = []
    rest = neuroom.Models.train(
        tiny_room, tmp_path, steps=STEPS, seed=0, progress=lambda *r: reports.append(r)
    )
    assert rest.complete and rest.names == names
    assert {stage for stage, _, _ in reports} >= set(rest.names[1:])
    assert "background" not in {stage for stage, _, _ in reports}, "finished models are kept"
    assert all(0 <= step <= total for _, step, total in reports if total)
    # The folder opens alone: the manifest records the room it was trained from.
    again = neuroom.Models.open(rest.path)
    assert again.room.name == neuroom.Room(tiny_room).name and again.complete


def test_the_command_trains_one_model_too(tiny_room: pathlib.Path, tmp_path: pathlib.Path) -> None:
    run_cli("train", tiny_room, "--out", tmp_path, "--object-steps", str(STEPS),
            "--background-steps", str(STEPS), "--only", "background")
    models = neuroom.Models.open(tmp_path / neuroom.Room(tiny_room).name)
    assert models.names == ["background"] and not models.complete


def test_ctrl_c_stops_training_and_it_resumes(tiny_room: pathlib.Path, tmp_path: pathlib.Path) -> None:
    started = threading.Event()

    def progress(stage: str, step: int, total: int) -> None:
        if step >= 5:
            started.set()

    def interrupt_when_started() -> None:
        if started.wait(60):
            _thread.interrupt_main()

    timer = threading.Thread(target=interrupt_when_started)
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        neuroom.Models.train(
            tiny_room, tmp_path, steps=RESUMED_STEPS, only=["background"], seed=0, progress=progress
        )
    timer.join()
    folder = tmp_path / neuroom.Room(tiny_room).name
    checkpoint = folder / "background" / "checkpoint" / "config.json"
    assert checkpoint.is_file(), "the interrupted model's checkpoint is saved"
    reports: list[tuple[str, int, int]] = []
    resumed = neuroom.Models.train(
        tiny_room, tmp_path, steps=RESUMED_STEPS, only=["background"], seed=0,
        progress=lambda *r: reports.append(r),
    )
    assert resumed.names == ["background"]
    assert reports[0][1] >= 5, "training resumes from the checkpoint, not from step 0"
    assert reports[-1][1] == RESUMED_STEPS
    assert not checkpoint.exists(), "a finished model keeps no checkpoint"


def test_a_raising_callback_stops_training(tiny_room: pathlib.Path, tmp_path: pathlib.Path) -> None:
    def progress(stage: str, step: int, total: int) -> None:
        if step >= 3:
            raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough"):
        neuroom.Models.train(tiny_room, tmp_path, steps=1000, only=["background"], progress=progress)


def test_tqdm_bars_are_progress(tiny_room: pathlib.Path, tmp_path: pathlib.Path) -> None:
    with tqdm.tqdm(file=io.StringIO()) as bar:
        neuroom.Models.train(tiny_room, tmp_path, steps=STEPS, only=["background"], progress=bar)
        assert bar.n == STEPS and bar.total == STEPS
