"""Turn a located arrangement into the messages a ROS 2 node would publish: one
`geometry_msgs/PoseStamped` per object and one for the camera, in the world (`map`) frame, and a
`visualization_msgs/MarkerArray` of the objects' boxes.

    python examples/ros2_poses.py ARRANGEMENT.json [--room ROOM]        # prints the messages
    python examples/ros2_poses.py ARRANGEMENT.json --publish            # with rclpy installed

Without ROS 2 (it cannot be installed everywhere) the messages are plain dictionaries with the
fields of the ROS 2 types, printed as JSON; with `--publish` and rclpy, a node publishes them.
"""

from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np

import neuroom

FRAME = "map"


def quaternion(rotation: np.ndarray) -> dict[str, float]:
    """A rotation matrix as a unit quaternion (x, y, z, w), the way geometry_msgs holds it."""
    m = rotation
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0:
        s = 2.0 * np.sqrt(trace + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        q = [0.0, 0.0, 0.0, (m[k, j] - m[j, k]) / s]
        q[i] = s / 4
        q[j] = (m[j, i] + m[i, j]) / s
        q[k] = (m[k, i] + m[i, k]) / s
    x, y, z, w = (float(v) for v in q)
    return {"x": x, "y": y, "z": z, "w": w}


def pose_stamped(matrix: np.ndarray, stamp: dict[str, int]) -> dict[str, Any]:
    """A 4×4 pose as a geometry_msgs/PoseStamped in the world frame."""
    x, y, z = (float(v) for v in matrix[:3, 3])
    return {
        "header": {"stamp": stamp, "frame_id": FRAME},
        "pose": {"position": {"x": x, "y": y, "z": z}, "orientation": quaternion(matrix[:3, :3])},
    }


def messages(arrangement: neuroom.Arrangement, stamp: dict[str, int]) -> dict[str, Any]:
    """The camera's pose, each object's pose by name, and the boxes as markers."""
    markers = []
    for o in arrangement.objects:
        if o.size is None:
            continue
        sx, sy, sz = o.size
        markers.append(
            {
                "header": {"stamp": stamp, "frame_id": FRAME},
                "ns": "neuroom",
                "id": o.id,
                "type": 1,  # CUBE
                "action": 0,  # ADD
                "pose": pose_stamped(o.pose, stamp)["pose"],
                "scale": {"x": sx, "y": sy, "z": sz},
                "color": {"r": 0.2, "g": 0.6, "b": 1.0, "a": 0.5},
                "text": o.name,
            }
        )
    return {
        "camera": pose_stamped(arrangement.camera_to_world, stamp),
        "objects": {o.name: pose_stamped(o.pose, stamp) for o in arrangement.objects},
        "markers": {"markers": markers},
    }


def publish(found: dict[str, Any]) -> None:
    """Publishes the poses once from a ROS 2 node (needs rclpy and geometry_msgs)."""
    import rclpy
    from geometry_msgs.msg import PoseStamped

    def message(d: dict[str, Any]) -> PoseStamped:
        msg = PoseStamped()
        msg.header.frame_id = d["header"]["frame_id"]
        p, q = d["pose"]["position"], d["pose"]["orientation"]
        msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = p["x"], p["y"], p["z"]
        o = msg.pose.orientation
        o.x, o.y, o.z, o.w = q["x"], q["y"], q["z"], q["w"]
        return msg

    rclpy.init()
    node = rclpy.create_node("neuroom_poses")
    node.create_publisher(PoseStamped, "neuroom/camera", 1).publish(message(found["camera"]))
    for name, pose in found["objects"].items():
        node.create_publisher(PoseStamped, f"neuroom/objects/{name}", 1).publish(message(pose))
    node.destroy_node()
    rclpy.shutdown()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("arrangement")
    parser.add_argument("--room", help="the room folder, for the objects' box sizes")
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args()
    arrangement = neuroom.Arrangement.read(args.arrangement, room=args.room)
    found = messages(arrangement, stamp={"sec": 0, "nanosec": 0})
    if args.publish:
        publish(found)
    else:
        print(json.dumps(found, indent=2))


if __name__ == "__main__":
    main()
