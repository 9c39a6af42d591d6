"""The package's API on a trained studio room: locate matches the command's, arrays in and out,
JSON round trips, rendering, editing and evaluation."""

from __future__ import annotations

import io
import json
import pathlib
import threading

import numpy as np
import pytest
import tqdm

import neuroom
from conftest import run_cli


@pytest.fixture(scope="session")
def panorama(studio_models: neuroom.Models) -> pathlib.Path:
    return studio_models.room.test_panoramas()[0][0]


Report = tuple[str, int, int]


@pytest.fixture(scope="session")
def locate_reports(
    studio_models: neuroom.Models, panorama: pathlib.Path
) -> tuple[neuroom.Arrangement, list[Report]]:
    reports: list[Report] = []
    located = studio_models.locate(panorama, progress=lambda *r: reports.append(r))
    return located, reports


@pytest.fixture(scope="session")
def located(locate_reports: tuple[neuroom.Arrangement, list[Report]]) -> neuroom.Arrangement:
    return locate_reports[0]


def test_locate_matches_the_command(
    studio_models: neuroom.Models,
    panorama: pathlib.Path,
    located: neuroom.Arrangement,
    tmp_path: pathlib.Path,
) -> None:
    out = tmp_path / "located.json"
    run_cli(
        "locate", studio_models.room.path, studio_models.path, panorama, "--out", out, "--no-fit"
    )
    command = neuroom.Arrangement.read(out)
    assert located.image == command.image == panorama.name
    np.testing.assert_allclose(located.camera_to_world, command.camera_to_world, atol=1e-9)
    assert [o.id for o in located.objects] == [o.id for o in command.objects]
    assert len(located) > 0
    for mine, theirs in zip(located.objects, command.objects):
        np.testing.assert_allclose(mine.pose, theirs.pose, atol=1e-9)
        assert mine.score == theirs.score
        assert mine.score is not None


def test_arrangement_fields(studio_models: neuroom.Models, located: neuroom.Arrangement) -> None:
    assert located.camera_to_world.shape == (4, 4)
    assert located.camera_to_world.dtype == np.float64
    confidence = located.camera_confidence
    assert confidence is not None and 0.0 <= confidence <= 1.0
    sizes = {o["id"]: o["size"] for o in studio_models.room.objects}
    for placed in located.objects:
        assert placed.pose.shape == (4, 4)
        assert placed.size == pytest.approx(sizes[placed.id])
        rotation = placed.pose[:3, :3]
        np.testing.assert_allclose(rotation.T @ rotation, np.eye(3), atol=1e-9)


def test_json_round_trip(studio_models: neuroom.Models, located: neuroom.Arrangement) -> None:
    text = located.to_json()
    again = neuroom.Arrangement.from_json(text, room=studio_models.room)
    # The reader re-orthonormalises poses (docs/formats.md), which may move their last bits.
    assert_same_json(json.loads(again.to_json()), json.loads(text))
    assert [o.size for o in again.objects] == [o.size for o in located.objects]
    assert [o.score for o in again.objects] == [o.score for o in located.objects]
    assert neuroom.Arrangement.from_json(text).objects[0].size is None


def assert_same_json(a: object, b: object) -> None:
    """The same JSON value, numbers equal to 1e-12."""
    if isinstance(a, dict) and isinstance(b, dict):
        assert a.keys() == b.keys()
        for k in a:
            assert_same_json(a[k], b[k])
    elif isinstance(a, list) and isinstance(b, list):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            assert_same_json(x, y)
    elif isinstance(a, float) or isinstance(b, float):
        assert a == pytest.approx(b, abs=1e-12)
    else:
        assert a == b


def test_locate_takes_arrays(
    studio_models: neuroom.Models, panorama: pathlib.Path, located: neuroom.Arrangement
) -> None:
    pixels = neuroom.read_image(panorama)
    assert pixels.dtype == np.float32 and pixels.shape[2] == 3
    assert pixels.shape[1] == 2 * pixels.shape[0]
    as_bytes = np.rint(pixels * 255.0).astype(np.uint8)
    for image in (pixels, as_bytes):
        from_array = studio_models.locate(image, name=panorama.name)
        np.testing.assert_allclose(from_array.camera_to_world, located.camera_to_world, atol=1e-6)
        assert [o.id for o in from_array.objects] == [o.id for o in located.objects]
        for mine, theirs in zip(from_array.objects, located.objects):
            np.testing.assert_allclose(mine.pose, theirs.pose, atol=1e-6)


def test_render_arrays(studio_models: neuroom.Models, located: neuroom.Arrangement) -> None:
    panorama = studio_models.render(located, width=128)
    assert panorama.rgb.shape == (64, 128, 3) and panorama.rgb.dtype == np.float32
    assert panorama.depth.shape == (64, 128) and panorama.depth.dtype == np.float32
    assert panorama.instance.shape == (64, 128) and panorama.instance.dtype == np.uint16
    assert 0.0 <= panorama.rgb.min() and panorama.rgb.max() <= 1.0
    assert (panorama.depth > 0).mean() > 0.9, "a closed room is hit all around"
    ids = {o.id for o in located.objects}
    assert set(np.unique(panorama.instance)) - {0} <= ids

    # A pinhole camera at the panorama's camera, looking along its +x (the centre column): OpenGL
    # frame, so the camera's −z is the panorama's +x and its +y the panorama's +z.
    pose = np.eye(4)
    pose[:3, :3] = located.camera_to_world[:3, :3] @ np.array(
        [[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    )
    pose[:3, 3] = located.camera_to_world[:3, 3]
    camera = neuroom.Pinhole(40.0, 40.0, 40.0, 30.0, 80, 60, pose)
    view = studio_models.render(located, camera)
    assert view.rgb.shape == (60, 80, 3)
    assert view.depth.shape == (60, 80) and (view.depth > 0).all()
    # The view's centre sees what the panorama's centre column sees at the horizon.
    centre_depth = float(view.depth[30, 40])
    horizon_distance = float(panorama.depth[32, 64])
    assert centre_depth == pytest.approx(horizon_distance, rel=0.15)
    # The same camera by where it stands and what it looks at.
    eye = located.camera_to_world[:3, 3]
    looking = neuroom.Pinhole.looking_at(eye, eye + located.camera_to_world[:3, 0], 80, 60, 90.0)
    ahead = located.camera_to_world[:3, 0] / np.linalg.norm(located.camera_to_world[:3, 0])
    np.testing.assert_allclose(-looking.camera_to_world[:3, 2], ahead, atol=1e-9)
    np.testing.assert_allclose(looking.camera_to_world[:3, 3], eye, atol=1e-12)
    assert abs(looking.camera_to_world[2, 0]) < 1e-12, "held level: its x axis is horizontal"
    assert (looking.fx, looking.cx, looking.cy) == pytest.approx((40.0, 40.0, 30.0))


def test_edit_moves_an_object(studio_models: neuroom.Models, located: neuroom.Arrangement) -> None:
    first = located.objects[0]
    edited = studio_models.edit(
        located, [{"op": "move", "object": first.id, "by": [0.1, 0.0, 0.0]}], settle=False
    )
    moved = next(o for o in edited.objects if o.id == first.id)
    np.testing.assert_allclose(moved.pose[:3, 3] - first.pose[:3, 3], [0.1, 0.0, 0.0], atol=1e-9)
    removed = studio_models.edit(located, [{"op": "remove", "object": first.name}])
    assert first.id not in [o.id for o in removed.objects]


def test_evaluate_scores_the_ground_truth_perfectly(studio_models: neuroom.Models) -> None:
    panorama, truth = studio_models.room.test_panoramas()[0]
    scores = neuroom.evaluate(studio_models.room, [truth])
    assert scores["rows"][0]["panorama"] == panorama.name
    assert scores["mean"]["iou_percent"] == pytest.approx(100.0)
    assert scores["mean"]["camera_position_error_cm"] == pytest.approx(0.0, abs=1e-6)


def test_locate_reports_each_stage(
    locate_reports: tuple[neuroom.Arrangement, list[Report]],
) -> None:
    _, reports = locate_reports
    stages = [stage for stage, _, _ in reports]
    assert stages[0] == "loading models" and stages[1] == "camera"
    assert stages[-1] == "located"
    for stage in ("empty room at the camera", "detection", "placing objects", "residual search"):
        assert stage in stages
    done = [step for _, step, _ in reports]
    assert done == sorted(done), "never backwards"
    assert {total for _, _, total in reports} == {done[-1]}, "one total, reached at the end"


def test_render_and_evaluate_report_progress(
    studio_models: neuroom.Models, located: neuroom.Arrangement
) -> None:
    reports: list[Report] = []
    threads: set[int] = set()

    def progress(stage: str, step: int, total: int) -> None:
        reports.append((stage, step, total))
        threads.add(threading.get_ident())

    studio_models.render(located, width=256, progress=progress)
    assert threads == {threading.get_ident()}, "callbacks run on the calling thread"
    assert {stage for stage, _, _ in reports} == {"render"}
    done = [step for _, step, _ in reports]
    assert len(done) > 2 and done == sorted(done)
    assert done[-1] == reports[-1][2] == 256 * 128, "every pixel"

    with tqdm.tqdm(file=io.StringIO()) as bar:
        _, truth = studio_models.room.test_panoramas()[0]
        neuroom.evaluate(studio_models.room, [truth, truth], progress=bar)
        assert (bar.n, bar.total) == (2, 2)


def test_a_raising_progress_callback_is_the_calls_error(
    studio_models: neuroom.Models, located: neuroom.Arrangement
) -> None:
    class Enough(Exception):
        pass

    def progress(stage: str, step: int, total: int) -> None:
        raise Enough(stage)

    with pytest.raises(Enough, match="render"):
        studio_models.render(located, width=64, progress=progress)
