"""Bad input raises the right exception, naming the file and the problem; nothing crashes."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

import neuroom


def test_missing_room_names_the_file(tmp_path: pathlib.Path) -> None:
    with pytest.raises(neuroom.NeuroomError, match="nowhere"):
        neuroom.Room(tmp_path / "nowhere")


def test_malformed_room_json(tmp_path: pathlib.Path) -> None:
    (tmp_path / "room.json").write_text("{ not json")
    with pytest.raises(neuroom.NeuroomError, match="room.json"):
        neuroom.Room(tmp_path)


def test_missing_models_name_the_manifest(tmp_path: pathlib.Path) -> None:
    with pytest.raises(neuroom.NeuroomError, match="manifest.json"):
        neuroom.Models.open(tmp_path)


def test_malformed_arrangement_json() -> None:
    with pytest.raises(neuroom.NeuroomError, match="format"):
        neuroom.Arrangement.from_json('{"objects": []}')
    with pytest.raises(neuroom.NeuroomError):
        neuroom.Arrangement.from_json("[1, 2")


def test_pinhole_checks_its_pose() -> None:
    scaled = 2.0 * np.eye(4)
    scaled[3, 3] = 1.0
    with pytest.raises(ValueError, match="orthonormal"):
        neuroom.Pinhole(50.0, 50.0, 32.0, 24.0, 64, 48, scaled)
    with pytest.raises(ValueError, match="4×4"):
        neuroom.Pinhole(50.0, 50.0, 32.0, 24.0, 64, 48, np.eye(3))
    with pytest.raises(ValueError, match="positive"):
        neuroom.Pinhole(50.0, 50.0, 32.0, 24.0, 0, 48, np.eye(4))


def test_unreadable_image(tmp_path: pathlib.Path) -> None:
    broken = tmp_path / "broken.png"
    broken.write_bytes(b"not a png")
    with pytest.raises(neuroom.NeuroomError, match="broken.png"):
        neuroom.read_image(broken)


def test_training_an_unknown_model(tiny_room: pathlib.Path, tmp_path: pathlib.Path) -> None:
    with pytest.raises(neuroom.NeuroomError, match="no model named"):
        neuroom.Models.train(tiny_room, tmp_path, steps=1, only=["sofa"])


def test_bad_progress_argument(tiny_room: pathlib.Path, tmp_path: pathlib.Path) -> None:
    with pytest.raises(TypeError, match="progress"):
        neuroom.Models.train(tiny_room, tmp_path, steps=1, progress=42)
