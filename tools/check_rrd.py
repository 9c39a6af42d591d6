#!/usr/bin/env python3
"""Opens a Rerun recording written by `neuroom export --rrd` with the matching rerun-sdk and checks it.

    python3 tools/check_rrd.py FILE.rrd [--arrangement SOLVED.json] [--truth GT.json] [--panorama IMAGE]

It needs `rerun-sdk==0.36.3` (the version of the `rerun` crate neuroom pins). Without it the script makes a
virtual environment in <repo>/.venv-rerun (git-ignored by a `.gitignore` of its own), installs rerun-sdk there from PyPI and runs
itself again inside it.

Checks, each printed as `ok ...` or `FAIL ...`:
- `rerun rrd verify FILE` accepts the file (it loads and every component matches its archetype);
- the file holds one recording of the application `neuroom`, written by the 0.36 SDK;
- `world` declares right-handed z-up view coordinates (Right, Forward, Up);
- `world/camera` has a Transform3D and axes; with `--arrangement`, its translation is the camera's;
- `world/meshes/room` and, with `--arrangement`, `world/meshes/<name>` of every object, are Mesh3D with
  one normal and one colour per vertex, unit normals and triangle indices in range, placed by a Transform3D
  (with `--arrangement`, the object's pose);
- `world/boxes/solved` and, with `--truth`, `world/boxes/truth` are Boxes3D labelled with the objects'
  names, centred where the arrangement places them;
- `panorama` is an EncodedImage (PNG or JPEG); with `--panorama`, the very bytes of that file.

Exit status: 0 when every check passes, 1 when one fails, 2 for a usage error.
"""

import argparse
import json
import math
import os
import subprocess
import sys
from pathlib import Path

RERUN_SDK = "rerun-sdk==0.36.3"
SDK_VERSION = "0.36.3"
REPO = Path(__file__).resolve().parent.parent
VENV = REPO / ".venv-rerun"
# rerun.datatypes.ViewDir: Up = 1, Right = 3, Forward = 5.
RIGHT_HAND_Z_UP = [3, 5, 1]
TOL = 1e-4


def ensure_rerun():
    """Imports rerun at SDK_VERSION, or re-runs this script inside a venv that has it."""
    try:
        import rerun

        if rerun.__version__ == SDK_VERSION:
            return rerun
    except ImportError:
        pass
    python = VENV / "bin" / "python"
    if Path(sys.prefix).resolve() == VENV.resolve():
        sys.exit(f"error: {RERUN_SDK} is not importable inside {VENV}")
    if not python.exists():
        print(f"making {VENV} with {RERUN_SDK}", file=sys.stderr)
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
        (VENV / ".gitignore").write_text("*\n")
    subprocess.run([str(python), "-m", "pip", "install", "-q", RERUN_SDK], check=True)
    os.execv(str(python), [str(python), __file__, *sys.argv[1:]])


class Checks:
    """Counts and prints passed and failed checks."""

    def __init__(self):
        self.failed = 0
        self.passed = 0

    def check(self, ok, what):
        print(("ok   " if ok else "FAIL ") + what)
        if ok:
            self.passed += 1
        else:
            self.failed += 1
        return ok


def close(a, b, tol=TOL):
    return len(a) == len(b) and all(abs(x - y) <= tol for x, y in zip(a, b))


def quat_close(a, b, tol=TOL):
    """Whether two unit quaternions (x, y, z, w) are the same rotation."""
    return abs(abs(sum(x * y for x, y in zip(a, b))) - 1.0) <= tol


def quat_of(m):
    """Unit quaternion (x, y, z, w) of a proper 3×3 rotation given as rows."""
    t = m[0][0] + m[1][1] + m[2][2]
    if t > 0:
        s = 2.0 * math.sqrt(1.0 + t)
        return [(m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, s / 4]
    i = max(range(3), key=lambda k: m[k][k])
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2.0 * math.sqrt(1.0 + m[i][i] - m[j][j] - m[k][k])
    q = [0.0, 0.0, 0.0, (m[k][j] - m[j][k]) / s]
    q[i] = s / 4
    q[j] = (m[j][i] + m[i][j]) / s
    q[k] = (m[k][i] + m[i][k]) / s
    return q


def pose_of(matrix):
    """(translation, quaternion) of a 4×4 pose written as rows."""
    return [row[3] for row in matrix[:3]], quat_of([row[:3] for row in matrix[:3]])


def read_entities(rr, path):
    """{entity path: {component: first row's value}} of the file's recording, and its store entries."""
    reader = rr.experimental.RrdReader(str(path))
    entities = {}
    for chunk in reader.store().stream():
        batch = chunk.to_record_batch()
        row = entities.setdefault(chunk.entity_path, {})
        for name in batch.schema.names:
            if not name.startswith("rerun.controls"):
                row[name] = batch.column(name).to_pylist()[0]
    return entities, reader.recordings()


def mono(values, component):
    """The one instance of a component logged as a single value (a row holds a list of instances)."""
    instances = values.get(component)
    return instances[0] if instances else None


def check_transform(c, entity, values, pose):
    """The entity's Transform3D, against `pose` (translation, quaternion) when given."""
    t, q = mono(values, "Transform3D:translation"), mono(values, "Transform3D:quaternion")
    if not c.check(t is not None and q is not None, f"{entity}: Transform3D translation and rotation"):
        return
    if pose is not None:
        c.check(close(t, pose[0]) and quat_close(q, pose[1]), f"{entity}: at the arrangement's pose")


def check_mesh(c, entity, values, pose=None):
    """A Mesh3D with per-vertex unit normals and colours, indices in range, placed by a transform."""
    positions = values.get("Mesh3D:vertex_positions")
    if not c.check(bool(positions), f"{entity}: Mesh3D with vertices"):
        return
    n = len(positions)
    normals = values.get("Mesh3D:vertex_normals") or []
    colors = values.get("Mesh3D:vertex_colors") or []
    triangles = values.get("Mesh3D:triangle_indices") or []
    c.check(len(normals) == n and len(colors) == n, f"{entity}: a normal and a colour per vertex ({n})")
    c.check(
        all(abs(math.sqrt(sum(x * x for x in v)) - 1.0) < 1e-3 for v in normals),
        f"{entity}: unit normals",
    )
    c.check(
        bool(triangles) and all(0 <= i < n for t in triangles for i in t),
        f"{entity}: {len(triangles)} triangles, indices in range",
    )
    check_transform(c, entity, values, pose)


def check_boxes(c, entity, values, arrangement):
    """Boxes3D labelled by object name, centred at the arrangement's poses when given."""
    labels = values.get("Boxes3D:labels")
    centers = values.get("Boxes3D:centers") or []
    halves = values.get("Boxes3D:half_sizes") or []
    quats = values.get("Boxes3D:quaternions") or []
    if not c.check(bool(labels), f"{entity}: Boxes3D with labels"):
        return
    c.check(
        len(centers) == len(labels) == len(halves) == len(quats),
        f"{entity}: {len(labels)} boxes with centre, half size and rotation",
    )
    c.check(all(h > 0 for hs in halves for h in hs), f"{entity}: positive sizes")
    if arrangement is None:
        return
    names = [o["name"] for o in arrangement["objects"]]
    c.check(sorted(labels) == sorted(names), f"{entity}: labels are the objects' names {names}")
    for o in arrangement["objects"]:
        if o["name"] in labels:
            k = labels.index(o["name"])
            t, q = pose_of(o["object_to_world"])
            c.check(
                close(centers[k], t) and quat_close(quats[k], q),
                f"{entity}: box of {o['name']} at its pose",
            )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("rrd", type=Path)
    parser.add_argument("--arrangement", type=Path, help="the exported (solved) arrangement")
    parser.add_argument("--truth", type=Path, help="the ground truth given to the export")
    parser.add_argument("--panorama", type=Path, help="the input panorama the recording must hold")
    args = parser.parse_args()
    if not args.rrd.is_file():
        parser.error(f"{args.rrd}: no such file")
    rr = ensure_rerun()
    c = Checks()
    rerun_cli = Path(sys.executable).parent / "rerun"
    verify = subprocess.run([str(rerun_cli), "rrd", "verify", str(args.rrd)], capture_output=True, text=True)
    c.check(verify.returncode == 0, f"rerun rrd verify: {(verify.stdout + verify.stderr).strip().splitlines()[-1:]}")
    entities, recordings = read_entities(rr, args.rrd)
    c.check(
        len(recordings) == 1 and recordings[0].application_id == "neuroom",
        f"one recording of application neuroom: {recordings}",
    )
    print(f"info entities: {sorted(entities)}")
    solved = json.loads(args.arrangement.read_text()) if args.arrangement else None
    truth = json.loads(args.truth.read_text()) if args.truth else None
    world = entities.get("/world", {})
    c.check(world.get("ViewCoordinates:xyz") == [RIGHT_HAND_Z_UP], "/world: view coordinates right-handed, z up")
    camera = entities.get("/world/camera", {})
    c.check("TransformAxes3D:axis_length" in camera, "/world/camera: drawn as axes")
    check_transform(c, "/world/camera", camera, pose_of(solved["camera_to_world"]) if solved else None)
    check_mesh(c, "/world/meshes/room", entities.get("/world/meshes/room", {}), ([0, 0, 0], [0, 0, 0, 1]))
    for o in (solved or {}).get("objects", []):
        entity = "/world/meshes/" + rr.escape_entity_path_part(o["name"])
        check_mesh(c, entity, entities.get(entity, {}), pose_of(o["object_to_world"]))
    check_boxes(c, "/world/boxes/solved", entities.get("/world/boxes/solved", {}), solved)
    if truth is not None:
        check_boxes(c, "/world/boxes/truth", entities.get("/world/boxes/truth", {}), truth)
    image = entities.get("/panorama", {})
    blob = bytes(mono(image, "EncodedImage:blob") or b"")
    media = mono(image, "EncodedImage:media_type")
    c.check(
        (media == "image/png" and blob[:4] == b"\x89PNG") or (media == "image/jpeg" and blob[:3] == b"\xff\xd8\xff"),
        f"/panorama: EncodedImage {media}, {len(blob)} bytes",
    )
    if args.panorama:
        c.check(blob == args.panorama.read_bytes(), f"/panorama: the bytes of {args.panorama}")
    print(f"{c.passed} passed, {c.failed} failed")
    return 1 if c.failed else 0


if __name__ == "__main__":
    sys.exit(main())
