#!/usr/bin/env python3
"""Writes `suite/README.md` from what the generator recorded in each room's `meta/generation.json`:
the rooms, their furniture with its provenance and licence, and every lighting. Run after
`tools/suite/make_suite.sh`:

    python3 tools/suite/describe_suite.py suite
"""

import json
import os
import sys

LICENCES = {
    "BlendSwap-CC-0": "CC0 (public domain)",
    "BlendSwap-CC-BY": "CC BY 3.0",
    "KatorLegaz": "CC BY 3.0 US (Andrew Kator & Jennifer Legaz)",
    "Scopia": "CC BY 3.0 (Emmanuel Puybaret / eTeks, Scopia Visual Interfaces Systems)",
}

HEADER = """# The validation suite: rooms rendered by Blender Cycles

Rooms that the project's own generator did not make: real furniture from the Sweet Home 3D catalog
(Debian `sweethome3d-furniture`), rendered by Blender {blender} Cycles with `tools/suite/make_room.py`
from the configs in `tools/suite/rooms/`, every test panorama under a lighting unlike the captures'.
`neuroom bench locate --suite suite ../shared/data/blender-lite` trains each room with step budgets and
locates every panorama (see `docs/validation-suite.md`).

Each room follows the project's room format (`docs/formats.md`): `room.json`, `captures/<object>/`
(the object alone at the origin of its canonical frame, lit by a Blender studio HDRI, JPEG colour,
16-bit z-depth in mm, instance mask), `captures/background/` (the empty room under its capture lighting),
`panoramas/<room>_a<k>_l<j>.jpg` (arrangement k under lighting j, JPEG quality 95 as a camera writes
it) with the ground-truth arrangement `.json` (its `lighting` says what lit it), the ray depth
`.depth.png` and the instance mask `.mask.png`, `meshes/<object>.ply` (the rendered mesh in the
canonical frame, metres) and `meta/generation.json` (the config, every asset's provenance, render times).
`in_room/` is a second room folder: every object captured standing on the floor in the middle of the
room under the room's capture lighting, as a user scans an object where it stands (its `room.json` gives
each capture's `capture_to_object`; its `captures/background` links to the room's own), for `neuroom bench masks
suite/<room>/in_room`.

Regenerate with `tools/suite/make_suite.sh suite` (Debian `blender`, `blender-data`, `python3-numpy`,
`sweethome3d-furniture`; about 15 minutes a room on 2 cores) and `tools/suite/make_suite.sh
--objects-in-room suite` (about a minute an object), then `python3 tools/suite/describe_suite.py suite`.
The same config renders the same room.

## Rooms

"""


def describe_room(folder):
    with open(os.path.join(folder, "meta", "generation.json")) as f:
        meta = json.load(f)
    cfg = meta["config"]
    size = cfg["room"]["size"]
    lines = [f"### {cfg['name']}", "",
             f"{size[0]} × {size[1]} m, {size[2]} m high; objects captured under Blender's "
             f"`{cfg['object_capture']['hdri']}` studio light, {cfg['object_capture']['views']} views "
             f"of {cfg['object_capture']['res']}²; the empty room under "
             f"“{cfg['capture_lighting']['description']}” ({cfg['background']['views']} views).", "",
             "| object | role | catalog model | pack (licence) | creator |", "|---|---|---|---|---|"]
    for spec in cfg["objects"]:
        source = spec.get("instance_of", spec["name"])
        asset = meta["objects"][source]["asset"]
        role = spec["role"] + (f", an instance of {source}" if "instance_of" in spec else "")
        lines.append(f"| {spec['name']} | {role} | {asset['catalog_name']} (`{asset['model']}`) | "
                     f"{asset['pack']} ({LICENCES.get(asset['pack'], '?')}) | {asset['creator']} |")
    lines += ["", "| lighting | panoramas | what lights the room |", "|---|---|---|"]
    arrangements = cfg["panoramas"]["arrangements"]
    for j, lighting in enumerate(cfg["panorama_lightings"]):
        used = lighting.get("arrangements", list(range(arrangements)))
        names = ", ".join(f"`{cfg['name']}_a{a}_l{j}`" for a in used)
        lines.append(f"| {lighting['name']} | {names} | {lighting['description']} |")
    return "\n".join(lines) + "\n", meta["blender"]


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "suite"
    rooms = sorted(d for d in os.listdir(root) if os.path.isfile(os.path.join(root, d, "room.json")))
    if not rooms:
        sys.exit(f"{root}: no room folders")
    sections, blender = [], "?"
    for room in rooms:
        text, blender = describe_room(os.path.join(root, room))
        sections.append(text)
    footer = ("\n## Licences\n\nThe renders are released under the licences of the models they show "
              "(CC0 or CC BY 3.0, as listed per object: credit the creators above). The environment "
              "maps are Blender's bundled studio lights (`datafiles/studiolights/world`, CC0). Room "
              "materials and lights are procedural.\n")
    with open(os.path.join(root, "README.md"), "w") as f:
        f.write(HEADER.format(blender=blender) + "\n".join(sections) + footer)


if __name__ == "__main__":
    main()
