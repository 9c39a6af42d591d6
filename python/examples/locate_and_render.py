"""Locate a panorama, print where every object stands, render the room from a new viewpoint into a
numpy array, and log both to Rerun (a recording file, or the viewer with --spawn).

    pip install rerun-sdk
    python examples/locate_and_render.py MODELS PANORAMA [--save room.rrd | --spawn]

MODELS is a model folder `neuroom train` (or `neuroom.Models.train`) wrote, e.g. models/studio.
"""

from __future__ import annotations

import argparse

import numpy as np
import rerun as rr

import neuroom


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("models")
    parser.add_argument("panorama")
    parser.add_argument("--save", default="room.rrd", help="recording to write")
    parser.add_argument("--spawn", action="store_true", help="open the Rerun viewer instead")
    args = parser.parse_args()

    models = neuroom.Models.open(args.models)
    arrangement = models.locate(args.panorama)
    camera = arrangement.camera_to_world
    print(f"camera at {camera[:3, 3].round(3)} (confidence {arrangement.camera_confidence:.2f})")
    for w in arrangement.warnings:
        print("warning:", w)
    for o in arrangement.objects:
        x, y, z = o.pose[:3, 3]
        yaw = np.degrees(np.arctan2(o.pose[1, 0], o.pose[0, 0]))
        print(f"{o.name:>16} (id {o.id}): at ({x:.2f}, {y:.2f}, {z:.2f}) m, heading {yaw:.0f}°")

    # A new viewpoint: half a metre behind the panorama's camera and 40 cm higher, looking at the
    # point 2 m ahead of it, half a metre lower.
    heading = camera[:3, 0]
    eye = camera[:3, 3] - 0.5 * heading + [0.0, 0.0, 0.4]
    target = camera[:3, 3] + 2.0 * heading - [0.0, 0.0, 0.5]
    pinhole = neuroom.Pinhole.looking_at(eye, target, width=640, height=480, fov_deg=70.0)
    view = models.render(arrangement, pinhole)
    pose = pinhole.camera_to_world
    print(f"rendered {view.rgb.shape[1]}×{view.rgb.shape[0]} from the new viewpoint")

    rr.init("neuroom", spawn=args.spawn)
    if not args.spawn:
        rr.save(args.save)
    rr.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    rr.log("panorama", rr.Image(neuroom.read_image(args.panorama)))
    for o in arrangement.objects:
        if o.size is not None:
            rr.log(
                f"world/objects/{o.name}",
                rr.Boxes3D(half_sizes=[np.asarray(o.size) / 2], labels=[o.name]),
                rr.Transform3D(translation=o.pose[:3, 3], mat3x3=o.pose[:3, :3]),
            )
    rr.log("world/view", rr.Transform3D(translation=pose[:3, 3], mat3x3=pose[:3, :3]))
    rr.log(
        "world/view/image",
        rr.Pinhole(
            focal_length=[pinhole.fx, pinhole.fy],
            width=pinhole.width,
            height=pinhole.height,
            camera_xyz=rr.ViewCoordinates.RUB,
        ),
    )
    rr.log("world/view/image", rr.Image((view.rgb * 255).astype(np.uint8)))
    rr.log("world/view/image/depth", rr.DepthImage(view.depth, meter=1.0))
    if not args.spawn:
        print(f"recording: {args.save}")


if __name__ == "__main__":
    main()
