"""Render one neuroom room with Blender Cycles: real furniture, its captures and test panoramas.

Run inside Blender (Debian `blender` 3.4, whose Python has numpy through `python3-numpy`):

    blender -b --python-exit-code 1 -P tools/suite/make_room.py -- \
        --config tools/suite/rooms/lounge.json --out suite/lounge

It writes a room folder in the project's format (docs/formats.md): `room.json`, `captures/<object>/`
(the object alone under an HDR environment: JPEG colour, z-depth and instance mask), `captures/background/`
(the empty room under its capture lighting), `panoramas/<room>_a<k>_l<j>.jpg` with their ground-truth
arrangement, ray depth and instance mask, `meshes/<object>.ply` (the rendered mesh in its canonical frame)
and `meta/generation.json` (the config, every asset's provenance, render times).

With `--objects-in-room` it renders only `in_room/` next to a room already rendered: a room folder whose
objects were captured standing in the middle of the room under its capture lighting, views inside the
room, the object's id in the masks and 0 on the room (the automatic masks' benchmark).

The furniture comes from the Sweet Home 3D catalog of the Debian package `sweethome3d-furniture`; the
environment maps for the object captures from Blender's own studio lights (`blender-data`). Everything
the room draws from is seeded by the config's `seed`: the same config renders the same room.

Conventions (checked by `neuroom info` and the project's Blender convention tests):
- a pinhole frame's `transform_matrix` is Blender's `camera.matrix_world` (OpenGL: looks along -z);
- the panorama camera frame has +x through the centre column, +y to the left, +z up;
- depth and instance values are sampled at exact pixel centres by a separate one-sample render with a
  0.01 px filter; pinhole depth is z-depth, panorama depth the distance along the ray;
- an object's canonical frame maps the Sweet Home 3D model (Y up, front +Z) to x = front, z = up,
  centred on its bounding box, scaled to the catalog's size; `size` = [depth, width, height].
"""

import argparse
import glob
import json
import math
import os
import random
import re
import shutil
import struct
import sys
import tempfile
import time
import zipfile
import zlib

import bpy
import numpy as np
from mathutils import Matrix, Vector

CATALOG_DIR = "/usr/share/sweethome3d/furniture"
STUDIO_LIGHTS = "/usr/share/blender/datafiles/studiolights/world"
PANORAMA_FROM_CAMERA = Matrix(((0, -1, 0, 0), (0, 0, 1, 0), (-1, 0, 0, 0), (0, 0, 0, 1)))
"""Maps the panorama frame (x forward, y left, z up) to Blender's camera frame (looks along -z, +y up)."""

NO_DEPTH_BEYOND_M = 60.0
"""Blender writes 1e10 where a ray hits nothing; anything this far is 'no surface'."""


# ----------------------------------------------------------------------------------------------
# Small helpers: PNG writing, colour temperature, JSON
# ----------------------------------------------------------------------------------------------


def write_png_gray16(path, values):
    """Writes `values` (H x W, integers in 0..65535) as a 16-bit greyscale PNG (Up filter, zlib 9)."""
    data = np.ascontiguousarray(values.astype(">u2")).view(np.uint8).reshape(values.shape[0], -1)
    up = data.copy()
    up[1:] = data[1:] - data[:-1]
    raw = np.concatenate([np.full((data.shape[0], 1), 2, np.uint8), up], axis=1).tobytes()
    h, w = values.shape

    def chunk(tag, body):
        return (struct.pack(">I", len(body)) + tag + body
                + struct.pack(">I", zlib.crc32(tag + body) & 0xFFFFFFFF))

    png = (b"\x89PNG\r\n\x1a\n"
           + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, 0, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw, 9))
           + chunk(b"IEND", b""))
    write_bytes(path, png)


def write_bytes(path, data):
    """Writes a file through a temporary name and a rename, so an interrupted run leaves no torn file."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(data)
    os.replace(tmp, path)


def write_json(path, value):
    write_bytes(path, (json.dumps(value, indent=1) + "\n").encode())


def kelvin_rgb(kelvin):
    """Linear RGB of a black body at `kelvin`, normalised to a largest channel of 1 (Tanner Helland's fit,
    converted from sRGB to linear)."""
    t = kelvin / 100.0
    if t <= 66:
        r = 255.0
        g = 99.4708025861 * math.log(t) - 161.1195681661
        b = 0.0 if t <= 19 else 138.5177312231 * math.log(t - 10) - 305.0447927307
    else:
        r = 329.698727446 * (t - 60) ** -0.1332047592
        g = 288.1221695283 * (t - 60) ** -0.0755148492
        b = 255.0
    srgb = [min(max(c / 255.0, 0.0), 1.0) for c in (r, g, b)]
    lin = [c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in srgb]
    m = max(lin)
    return [round(c / m, 4) for c in lin]


def matrix_rows(m):
    return [[round(float(m[i][j]), 6) for j in range(4)] for i in range(4)]


# ----------------------------------------------------------------------------------------------
# The Sweet Home 3D catalog
# ----------------------------------------------------------------------------------------------


def parse_properties(text):
    """`key#N=value` lines of a PluginFurnitureCatalog.properties, as {N: {key: value}}."""
    entries = {}
    for line in text.splitlines():
        m = re.match(r"(\w+)#(\d+)=(.*)", line)
        if m:
            value = re.sub(r"\\u([0-9a-fA-F]{4})", lambda u: chr(int(u.group(1), 16)), m.group(3))
            entries.setdefault(int(m.group(2)), {})[m.group(1)] = value
    return entries


class Catalog:
    """The `.sh3f` archives of a catalog folder, looked up by pack and model id."""

    def __init__(self, folder):
        self.packs = {}
        for path in sorted(glob.glob(os.path.join(folder, "*.sh3f"))):
            archive = zipfile.ZipFile(path)
            text = archive.read("PluginFurnitureCatalog.properties").decode("latin-1")
            self.packs[os.path.splitext(os.path.basename(path))[0]] = (archive, parse_properties(text))
        if not self.packs:
            sys.exit(f"{folder}: no Sweet Home 3D catalog (.sh3f); apt-get install sweethome3d-furniture")

    def entry(self, pack, model):
        """The catalog entry whose id ends in `#model`, with its index and archive."""
        if pack not in self.packs:
            sys.exit(f"unknown pack {pack!r}; the catalog has {sorted(self.packs)}")
        archive, entries = self.packs[pack]
        for index, e in sorted(entries.items()):
            if e.get("id", "").split("#")[-1] == model:
                return archive, index, e
        sys.exit(f"pack {pack!r} has no model {model!r}")


def extract_model(archive, entry, folder):
    """Extracts the OBJ of `entry` and the files beside it; returns the OBJ path. Faces of fewer than three
    vertices are dropped from the OBJ: Blender 3.4's importer skips them but leaves the mesh corrupt
    (seen as a crash a few operations later)."""
    obj = entry["model"].lstrip("/")
    prefix = os.path.dirname(obj) + "/"
    for name in archive.namelist():
        if name.startswith(prefix) and not name.endswith("/"):
            archive.extract(name, folder)
    path = os.path.join(folder, obj)
    with open(path, encoding="latin-1") as f:
        lines = [line for line in f if not (line.startswith("f ") and len(line.split()) < 4)]
    with open(path, "w", encoding="latin-1") as f:
        f.writelines(lines)
    return path


# ----------------------------------------------------------------------------------------------
# Scene building
# ----------------------------------------------------------------------------------------------


def reset_scene(threads):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.use_denoising = False
    sc.cycles.seed = 0
    sc.cycles.max_bounces = 6
    sc.cycles.diffuse_bounces = 3
    sc.cycles.glossy_bounces = 3
    sc.cycles.transmission_bounces = 6
    sc.cycles.transparent_max_bounces = 8
    sc.cycles.sample_clamp_indirect = 10.0
    sc.render.threads_mode = "FIXED"
    sc.render.threads = threads
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0.0
    sc.view_settings.gamma = 1.0
    world = bpy.data.worlds.new("world")
    sc.world = world
    return sc


def import_furniture(catalog, spec, workdir, log):
    """Imports the catalog model of `spec` as one mesh object in its canonical frame (see the module doc)
    and returns (object, size, provenance)."""
    archive, index, e = catalog.entry(spec["pack"], spec["model"])
    obj_path = extract_model(archive, e, os.path.join(workdir, spec["name"]))
    before = set(bpy.data.objects)
    bpy.ops.wm.obj_import(filepath=obj_path)
    parts = [o for o in bpy.data.objects if o not in before and o.type == "MESH"]
    if not parts:
        sys.exit(f"{obj_path}: no mesh imported")
    for o in parts:
        o.data.validate(clean_customdata=False)
    for o in bpy.data.objects:
        o.select_set(o in parts)
    bpy.context.view_layer.objects.active = parts[0]
    if len(parts) > 1:
        bpy.ops.object.join()
    ob = bpy.context.view_layer.objects.active
    ob.name = spec["name"]
    bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)
    # Blender's importer maps OBJ (X, Y, Z) to (X, -Z, Y). The catalog's optional model rotation acts in
    # OBJ coordinates first.
    obj_to_blender = Matrix(((1, 0, 0, 0), (0, 0, -1, 0), (0, 1, 0, 0), (0, 0, 0, 1)))
    if "modelRotation" in e:
        r = [float(x) for x in e["modelRotation"].split()]
        rot = Matrix(((r[0], r[1], r[2], 0), (r[3], r[4], r[5], 0), (r[6], r[7], r[8], 0), (0, 0, 0, 1)))
        ob.data.transform(obj_to_blender @ rot @ obj_to_blender.inverted())
    # Canonical frame: x = OBJ +Z (front) = Blender -y, y = OBJ X = Blender x, z = up.
    ob.data.transform(Matrix.Rotation(math.pi / 2, 4, "Z"))
    co = np.array([v.co[:] for v in ob.data.vertices])
    lo, hi = co.min(0), co.max(0)
    width, depth, height = (float(e["width"]) / 100, float(e["depth"]) / 100, float(e["height"]) / 100)
    size = [round(depth, 4), round(width, 4), round(height, 4)]
    scale = [s / max(h - l, 1e-9) for s, l, h in zip(size, lo, hi)]
    centre = (lo + hi) / 2
    ob.data.transform(Matrix.Diagonal(Vector(scale + [1.0])) @ Matrix.Translation(Vector(-centre)))
    ob.data.update()
    missing = [img.filepath for img in bpy.data.images if img.source == "FILE" and not img.has_data]
    if missing:
        log.append(f"{spec['name']}: textures that did not load: {missing}")
    provenance = {
        "pack": spec["pack"],
        "model": spec["model"],
        "catalog_name": e.get("name"),
        "catalog_category": e.get("category"),
        "creator": e.get("creator"),
        "catalog_index": index,
        "obj": "/" + e["model"].lstrip("/"),
        "anisotropic_scale_from_obj_cm": [round(s * 100, 4) for s in scale],
    }
    return ob, size, provenance


def write_ply(path, ob):
    """The mesh of `ob` (in its own frame) as a binary little-endian PLY of triangles, metres."""
    mesh = ob.data
    mesh.calc_loop_triangles()
    verts = np.array([v.co[:] for v in mesh.vertices], np.float32)
    tris = np.array([t.vertices[:] for t in mesh.loop_triangles], np.int32)
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(verts)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              f"element face {len(tris)}\nproperty list uchar int vertex_indices\nend_header\n")
    faces = np.zeros(len(tris), dtype=[("n", "u1"), ("v", "<i4", 3)])
    faces["n"] = 3
    faces["v"] = tris
    write_bytes(path, header.encode() + verts.astype("<f4").tobytes() + faces.tobytes())


def material(name, color, roughness=0.6, texture=None, scale=1.0, color2=None):
    """A Principled material of `color`, optionally modulated by a procedural texture
    ("planks", "tiles", "plaster", "checker")."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    bsdf = nt.nodes["Principled BSDF"]
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Base Color"].default_value = list(color) + [1.0]
    if texture is None:
        return m
    coord = nt.nodes.new("ShaderNodeTexCoord")
    second = list(color2 or [c * 0.7 for c in color]) + [1.0]
    if texture in ("planks", "tiles"):
        tex = nt.nodes.new("ShaderNodeTexBrick")
        tex.inputs["Color1"].default_value = list(color) + [1.0]
        tex.inputs["Color2"].default_value = second
        tex.inputs["Mortar"].default_value = [c * 0.5 for c in color] + [1.0]
        tex.inputs["Scale"].default_value = scale
        tex.inputs["Mortar Size"].default_value = 0.004 if texture == "planks" else 0.01
        tex.inputs["Brick Width"].default_value = 1.2 if texture == "planks" else 0.5
        tex.inputs["Row Height"].default_value = 0.18 if texture == "planks" else 0.5
        tex.offset = 0.37 if texture == "planks" else 0.0
        nt.links.new(coord.outputs["Object"], tex.inputs["Vector"])
        nt.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    elif texture == "checker":
        tex = nt.nodes.new("ShaderNodeTexChecker")
        tex.inputs["Color1"].default_value = list(color) + [1.0]
        tex.inputs["Color2"].default_value = second
        tex.inputs["Scale"].default_value = scale
        nt.links.new(coord.outputs["Object"], tex.inputs["Vector"])
        nt.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    elif texture == "plaster":
        tex = nt.nodes.new("ShaderNodeTexNoise")
        tex.inputs["Scale"].default_value = scale
        ramp = nt.nodes.new("ShaderNodeValToRGB")
        ramp.color_ramp.elements[0].color = second
        ramp.color_ramp.elements[1].color = list(color) + [1.0]
        nt.links.new(coord.outputs["Object"], tex.inputs["Vector"])
        nt.links.new(tex.outputs["Fac"], ramp.inputs["Fac"])
        nt.links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
    return m


def box(name, lo, hi, mat):
    """An axis-aligned box mesh from `lo` to `hi` with material `mat`."""
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    ob = bpy.context.object
    ob.name = name
    ob.scale = [h - l for l, h in zip(lo, hi)]
    ob.location = [(l + h) / 2 for l, h in zip(lo, hi)]
    bpy.ops.object.transform_apply(location=True, rotation=False, scale=True)
    ob.data.materials.append(mat)
    return ob


def emission_material(name, color, strength):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    e = nt.nodes.new("ShaderNodeEmission")
    e.inputs["Color"].default_value = list(color) + [1.0]
    e.inputs["Strength"].default_value = strength
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(e.outputs[0], out.inputs[0])
    return m


WALLS = {
    # name: (axis along the wall, fixed coordinate index, at max?, inward normal)
    "x0": (1, 0, False, (1, 0)),
    "x1": (1, 0, True, (-1, 0)),
    "y0": (0, 1, False, (0, 1)),
    "y1": (0, 1, True, (0, -1)),
}


def wall_rect(size, wall, at, width, z0, z1, depth):
    """lo/hi of a thin box on `wall` centred `at` metres along it, `depth` metres thick into the room."""
    along, fixed, at_max, _ = WALLS[wall]
    lo, hi = [0.0, 0.0, z0], [0.0, 0.0, z1]
    lo[along], hi[along] = at - width / 2, at + width / 2
    if at_max:
        lo[fixed], hi[fixed] = size[fixed] - depth, size[fixed] + 0.001
    else:
        lo[fixed], hi[fixed] = -0.001, depth
    return lo, hi


def build_room(cfg):
    """The room shell: floor, ceiling, walls, skirting, door, pictures, windows and fixed items."""
    size = cfg["size"]
    sx, sy, sz = size
    floor = cfg["floor"]
    fmat = material("floor", floor["color"], floor.get("roughness", 0.4), floor.get("texture"),
                    floor.get("scale", 1.0), floor.get("color2"))
    wmat = material("wall", cfg["wall_color"], 0.8, "plaster", 6.0,
                    [c * 0.93 for c in cfg["wall_color"]])
    cmat = material("ceiling", cfg.get("ceiling_color", [0.85, 0.85, 0.83]), 0.9)
    t = 0.05
    box("floor", (-t, -t, -t), (sx + t, sy + t, 0.0), fmat)
    box("ceiling", (-t, -t, sz), (sx + t, sy + t, sz + t), cmat)
    walls = {"x0": ((-t, -t, 0), (0, sy + t, sz)), "x1": ((sx, -t, 0), (sx + t, sy + t, sz)),
             "y0": ((-t, -t, 0), (sx + t, 0, sz)), "y1": ((-t, sy, 0), (sx + t, sy + t, sz))}
    for name, (lo, hi) in walls.items():
        mat = wmat
        if cfg.get("accent_wall") == name:
            mat = material("accent", cfg["accent_color"], 0.8, "plaster", 6.0,
                           [c * 0.93 for c in cfg["accent_color"]])
        box("wall_" + name, lo, hi, mat)
    skirt = material("skirting", cfg.get("skirting_color", [0.9, 0.9, 0.88]), 0.5)
    for wall in WALLS:
        length = size[WALLS[wall][0]]
        box("skirting_" + wall, *wall_rect(size, wall, length / 2, length, 0.0, 0.08, 0.015), skirt)
    for k, d in enumerate(cfg.get("doors", [])):
        dm = material(f"door{k}", d["color"], 0.5)
        box(f"door{k}", *wall_rect(size, d["wall"], d["at"], d["width"], 0.0, 2.05, 0.03), dm)
        frame = material(f"doorframe{k}", [0.92, 0.92, 0.9], 0.5)
        box(f"doorframe{k}", *wall_rect(size, d["wall"], d["at"], d["width"] + 0.12, 0.0, 2.11, 0.02), frame)
        handle = material(f"handle{k}", [0.8, 0.78, 0.7], 0.25)
        along, fixed, at_max, _ = WALLS[d["wall"]]
        hat = d["at"] + d["width"] * 0.38
        box(f"handle{k}", *wall_rect(size, d["wall"], hat, 0.12, 1.0, 1.04, 0.07), handle)
    for k, p in enumerate(cfg.get("pictures", [])):
        pm = material(f"picture{k}", p["color1"], 0.4, "checker", p.get("scale", 3.0), p["color2"])
        box(f"picture{k}", *wall_rect(size, p["wall"], p["at"], p["width"], p["z"] - p["height"] / 2,
                                      p["z"] + p["height"] / 2, 0.025), pm)
    for k, s in enumerate(cfg.get("fixed", [])):
        sm = material(f"fixed{k}", s["color"], s.get("roughness", 0.5))
        box(f"fixed{k}", s["min"], s["max"], sm)
    return size


def add_window(size, spec, lighting_on, index):
    """A window on a wall: a frame, and a pane that glows with the daylight of `spec` when
    `lighting_on` (else the dark blue of a night sky)."""
    along, fixed, at_max, normal = WALLS[spec["wall"]]
    z0, z1 = spec["sill"], spec["sill"] + spec["height"]
    frame = material(f"windowframe{index}", [0.93, 0.93, 0.92], 0.4)
    box(f"windowframe{index}", *wall_rect(size, spec["wall"], spec["at"], spec["width"] + 0.1,
                                          z0 - 0.05, z1 + 0.05, 0.02), frame)
    color = kelvin_rgb(spec.get("kelvin", 7000)) if lighting_on else [0.05, 0.07, 0.12]
    strength = spec.get("pane_strength", 3.0) if lighting_on else 0.3
    box(f"windowpane{index}", *wall_rect(size, spec["wall"], spec["at"], spec["width"], z0, z1, 0.025),
        emission_material(f"pane{index}", color, strength))


def add_lights(size, lighting, windows):
    """The lights of a lighting description; returns its description with world positions."""
    described = []
    active_windows = set(lighting.get("windows", []))
    for k, w in enumerate(windows):
        add_window(size, w, k in active_windows, k)
    for k, light in enumerate(lighting["lights"]):
        kind = light["type"]
        pos = [light["rel"][i] * size[i] if i < 2 else
               (size[2] + light["rel"][2] if light["rel"][2] < 0 else light["rel"][2]) for i in range(3)]
        color = light.get("color") or kelvin_rgb(light["kelvin"])
        data = bpy.data.lights.new(f"light{k}", "AREA" if kind == "WINDOW" else kind)
        data.color = color
        data.energy = light["power"]
        ob = bpy.data.objects.new(f"light{k}", data)
        bpy.context.scene.collection.objects.link(ob)
        ob.location = pos
        entry = {"type": kind, "position": [round(p, 3) for p in pos], "power_w": light["power"],
                 "kelvin": light.get("kelvin"), "color_rgb_linear": color}
        if kind == "AREA":
            data.shape = "RECTANGLE"
            data.size, data.size_y = light["size"]
            entry["size"] = light["size"]
            # Faces down.
        elif kind == "WINDOW":
            w = windows[light["window"]]
            along, fixed, at_max, normal = WALLS[w["wall"]]
            data.shape = "RECTANGLE"
            data.size, data.size_y = w["width"], w["height"]
            p = [0.0, 0.0, w["sill"] + w["height"] / 2]
            p[along] = w["at"]
            p[fixed] = size[fixed] - 0.03 if at_max else 0.03
            ob.location = p
            # An area light emits along its -z: turn -z to the room's inward normal.
            ob.rotation_euler = Vector((normal[0], normal[1], 0.0)).to_track_quat("-Z", "Y").to_euler()
            entry["position"] = [round(x, 3) for x in p]
            entry["window"] = light["window"]
        elif kind == "POINT":
            data.shadow_soft_size = light.get("radius", 0.05)
            entry["radius"] = data.shadow_soft_size
            if light.get("bulb", True):
                bulb = emission_material(f"bulb{k}", color, 30.0)
                bpy.ops.mesh.primitive_uv_sphere_add(radius=data.shadow_soft_size, location=pos)
                bpy.context.object.data.materials.append(bulb)
                bpy.context.object.visible_shadow = False
        elif kind == "SPOT":
            data.shadow_soft_size = light.get("radius", 0.05)
            data.spot_size = math.radians(light["spot_deg"])
            data.spot_blend = light.get("blend", 0.3)
            target = [light["target_rel"][i] * size[i] for i in range(3)]
            direction = Vector(target) - Vector(pos)
            ob.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
            entry.update({"target": [round(x, 3) for x in target], "spot_deg": light["spot_deg"]})
        described.append(entry)
    world = bpy.context.scene.world
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = lighting.get("ambient", 0.0)
    return {"name": lighting["name"], "description": lighting["description"], "lights": described,
            "windows_lit": sorted(active_windows), "exposure_ev": lighting.get("exposure_ev", 0.0)}


def set_hdri(path, strength):
    world = bpy.context.scene.world
    world.use_nodes = True
    nt = world.node_tree
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(path)
    bg = nt.nodes["Background"]
    bg.inputs["Strength"].default_value = strength
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])


# ----------------------------------------------------------------------------------------------
# Rendering: colour, then exact depth and instance passes
# ----------------------------------------------------------------------------------------------


class Passes:
    """Renders depth and instance ids at exact pixel centres: a one-sample render with a 0.01 px filter
    whose Depth and IndexOB passes go to a float EXR, read back with numpy."""

    def __init__(self, workdir):
        self.dir = os.path.join(workdir, "passes")
        sc = bpy.context.scene
        vl = sc.view_layers[0]
        vl.use_pass_z = True
        vl.use_pass_object_index = True
        sc.use_nodes = True
        nt = sc.node_tree
        nt.nodes.clear()
        rl = nt.nodes.new("CompositorNodeRLayers")
        comb = nt.nodes.new("CompositorNodeCombRGBA")
        nt.links.new(rl.outputs["Depth"], comb.inputs[0])
        nt.links.new(rl.outputs["IndexOB"], comb.inputs[1])
        out = nt.nodes.new("CompositorNodeOutputFile")
        out.base_path = self.dir
        out.format.file_format = "OPEN_EXR"
        out.format.color_depth = "32"
        out.format.color_mode = "RGB"
        out.file_slots[0].path = "pass"
        nt.links.new(comb.outputs[0], out.inputs[0])
        comp = nt.nodes.new("CompositorNodeComposite")
        nt.links.new(rl.outputs["Image"], comp.inputs[0])
        self.output = out
        self.output.mute = True

    def render(self):
        """Returns (depth in metres with 0 = none, instance ids) of the current camera."""
        sc = bpy.context.scene
        saved = (sc.cycles.samples, sc.cycles.filter_width, sc.render.filepath)
        shutil.rmtree(self.dir, ignore_errors=True)
        sc.cycles.samples, sc.cycles.filter_width = 1, 0.01
        self.output.mute = False
        bpy.ops.render.render(write_still=False)
        self.output.mute = True
        sc.cycles.samples, sc.cycles.filter_width, sc.render.filepath = saved
        path = glob.glob(os.path.join(self.dir, "pass*.exr"))[0]
        img = bpy.data.images.load(path)
        img.colorspace_settings.name = "Non-Color"
        w, h = img.size
        a = np.empty(w * h * 4, np.float32)
        img.pixels.foreach_get(a)
        bpy.data.images.remove(img)
        a = a.reshape(h, w, 4)[::-1]
        depth = a[..., 0].astype(np.float64)
        depth[depth > NO_DEPTH_BEYOND_M] = 0.0
        return depth, np.rint(a[..., 1]).astype(np.int64)


JPEG_QUALITY = {"capture": 92, "panorama": 95}
"""JPEG qualities of the colour images: what a camera writes, and a room small enough to commit."""


def render_color(path, samples, quality):
    """Renders the colour image to `path`, a JPEG of `quality` (an object capture's transparent
    background comes out black; its mask says which pixels are the object)."""
    sc = bpy.context.scene
    sc.cycles.samples = samples
    sc.cycles.filter_width = 1.5
    sc.render.image_settings.file_format = "JPEG"
    sc.render.image_settings.color_mode = "RGB"
    sc.render.image_settings.quality = quality
    tmp = path[:-4] + ".tmp.jpg"
    sc.render.filepath = tmp
    bpy.ops.render.render(write_still=True)
    os.replace(tmp, path)


def save_depth_mask(depth, ids, depth_path, mask_path):
    write_png_gray16(depth_path, np.clip(np.rint(depth * 1000.0), 0, 65535).astype(np.int64))
    write_png_gray16(mask_path, ids)


def save_frame(folder, name, depth, ids, cam):
    """Writes a capture frame's depth and mask beside its colour image; returns its transforms entry."""
    save_depth_mask(depth, ids, os.path.join(folder, "depths", name + ".png"),
                    os.path.join(folder, "masks", name + ".png"))
    return {"file_path": f"images/{name}.jpg", "depth_file_path": f"depths/{name}.png",
            "instance_file_path": f"masks/{name}.png", "transform_matrix": matrix_rows(cam.matrix_world)}


def camera_object(pano=False):
    cam = bpy.data.cameras.new("camera")
    if pano:
        cam.type = "PANO"
        cam.cycles.panorama_type = "EQUIRECTANGULAR"
    ob = bpy.data.objects.new("camera", cam)
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.scene.camera = ob
    return ob


def look_at(eye, target):
    """Blender camera world matrix at `eye` looking at `target`, +y up as level as possible."""
    forward = Vector(target) - Vector(eye)
    rot = forward.to_track_quat("-Z", "Y").to_matrix().to_4x4()
    return Matrix.Translation(Vector(eye)) @ rot


# ----------------------------------------------------------------------------------------------
# The three kinds of renders
# ----------------------------------------------------------------------------------------------


class CaptureRing:
    """Where an object capture's views stand around the object's centre: elevations evenly spread
    over the config's band (sine-spaced, for even area), azimuths on a golden spiral, each distance
    and aim jittered a little."""

    def __init__(self, cap, radius, distance):
        self.lo = math.sin(math.radians(cap["el_min_deg"]))
        self.hi = math.sin(math.radians(cap["el_max_deg"]))
        self.radius, self.distance = radius, distance

    def view(self, k, views, rng):
        """The k-th of `views` views: (eye, point looked at), both relative to the object's centre."""
        el = math.asin(self.lo + (self.hi - self.lo) * ((k + 0.5) / views))
        az = k * GOLDEN_ANGLE + rng.uniform(-0.1, 0.1)
        d = self.distance * rng.uniform(0.95, 1.1)
        eye = (d * math.cos(el) * math.cos(az), d * math.cos(el) * math.sin(az), d * math.sin(el))
        target = [rng.uniform(-0.05, 0.05) * self.radius for _ in range(3)]
        return eye, target


GOLDEN_ANGLE = math.pi * (3 - math.sqrt(5))
"""Radians between successive azimuths of a capture's views: no two views line up."""


def capture_camera(cap, size):
    """The scene's pinhole camera for an object capture of `cap` (its resolution and field of view)
    and the ring its views stand on, far enough that an object of `size` fills most of the frame:
    (camera object, focal length in pixels, ring)."""
    res = cap["res"]
    bpy.context.scene.render.resolution_x = bpy.context.scene.render.resolution_y = res
    cam = camera_object()
    cam.data.sensor_fit = "HORIZONTAL"
    cam.data.angle = math.radians(cap["fov_deg"])
    fl = res / 2 / math.tan(math.radians(cap["fov_deg"]) / 2)
    radius = 0.5 * math.sqrt(sum(s * s for s in size))
    distance = 0.9 * radius / math.sin(math.radians(cap["fov_deg"]) / 2)
    return cam, fl, CaptureRing(cap, radius, distance)


def write_capture_transforms(folder, res, fl, frames, lighting):
    """An object capture's transforms.json: square frames of `res` pixels, focal length `fl`."""
    write_json(os.path.join(folder, "transforms.json"), {
        "camera_model": "OPENCV", "fl_x": fl, "fl_y": fl, "cx": res / 2, "cy": res / 2, "w": res, "h": res,
        "k1": 0, "k2": 0, "p1": 0, "p2": 0, "depth_unit_scale_factor": 0.001, "frames": frames,
        "lighting": lighting})


def capture_object(catalog, spec, oid, cfg, out, workdir, threads):
    """Captures of one object alone at the origin of its canonical frame under an HDR environment."""
    cap = cfg["object_capture"]
    sc = reset_scene(threads)
    log = []
    ob, size, provenance = import_furniture(catalog, spec, workdir, log)
    ob.pass_index = oid
    write_ply(os.path.join(out, "meshes", spec["name"] + ".ply"), ob)
    set_hdri(os.path.join(STUDIO_LIGHTS, cap["hdri"]), cap.get("hdri_strength", 1.0))
    sc.render.film_transparent = True
    cam, fl, ring = capture_camera(cap, size)
    passes = Passes(workdir)
    rng = random.Random(f"{cfg['seed']}/{spec['name']}")
    folder = os.path.join(out, "captures", spec["name"])
    frames = []
    start = time.time()
    for k in range(cap["views"]):
        eye, target = ring.view(k, cap["views"], rng)
        cam.matrix_world = look_at(eye, target)
        bpy.context.view_layer.update()
        name = f"{k:04d}"
        render_color(os.path.join(folder, "images", name + ".jpg"), cap["samples"], JPEG_QUALITY["capture"])
        depth, ids = passes.render()
        ids[ids != oid] = 0
        frames.append(save_frame(folder, name, depth, ids, cam))
    write_capture_transforms(folder, cap["res"], fl, frames,
                             {"name": "hdri_" + os.path.splitext(cap["hdri"])[0], "hdri": cap["hdri"]})
    return size, {"size": size, "asset": provenance, "log": log,
                  "render_seconds": round(time.time() - start, 1), "views": cap["views"]}


def capture_background(cfg, out, workdir, threads):
    """Pinhole captures of the empty room under its capture lighting, every view looking across it."""
    bg = cfg["background"]
    sc = reset_scene(threads)
    size = build_room(cfg["room"])
    lighting = add_lights(size, cfg["capture_lighting"], cfg["room"].get("windows", []))
    sc.render.resolution_x, sc.render.resolution_y = bg["w"], bg["h"]
    cam = camera_object()
    cam.data.sensor_fit = "HORIZONTAL"
    cam.data.angle = 2 * math.atan(bg["w"] / 2 / bg["fl"])
    passes = Passes(workdir)
    rng = random.Random(f"{cfg['seed']}/background")
    folder = os.path.join(out, "captures", "background")
    frames = []
    start = time.time()
    for k in range(bg["views"]):
        eye = (rng.uniform(0.4, size[0] - 0.4), rng.uniform(0.4, size[1] - 0.4), rng.uniform(0.8, 1.8))
        while True:
            # A target on the far side: at least 1.5 m away, at pitch -35..20 degrees.
            yaw = rng.uniform(-math.pi, math.pi)
            pitch = math.radians(rng.uniform(-35, 20))
            direction = Vector((math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw),
                                math.sin(pitch)))
            free = min(wall_distance(eye, direction, size), 99.0)
            if free >= 1.5:
                break
        cam.matrix_world = look_at(eye, Vector(eye) + direction)
        bpy.context.view_layer.update()
        name = f"{k:04d}"
        render_color(os.path.join(folder, "images", name + ".jpg"), bg["samples"], JPEG_QUALITY["capture"])
        depth, ids = passes.render()
        frames.append(save_frame(folder, name, depth, ids, cam))
    write_json(os.path.join(folder, "transforms.json"), {
        "camera_model": "OPENCV", "fl_x": bg["fl"], "fl_y": bg["fl"], "cx": bg["w"] / 2, "cy": bg["h"] / 2,
        "w": bg["w"], "h": bg["h"], "k1": 0, "k2": 0, "p1": 0, "p2": 0, "depth_unit_scale_factor": 0.001, "frames": frames, "lighting": lighting})
    return {"views": bg["views"], "render_seconds": round(time.time() - start, 1), "lighting": lighting}


IN_ROOM_MARGIN_M = 0.2
"""How far inside the walls, floor and ceiling an in-room capture's eye stays."""

IN_ROOM_VIEWS = 24
"""Views of an in-room capture: enough for the masks' carving across views, and half the isolated
captures' so that the suite stays small enough to commit."""


def capture_object_in_room(catalog, spec, oid, cfg, out, workdir, threads):
    """Captures of one object standing on the floor in the middle of the empty room, turned by a seeded
    heading, under the room's capture lighting: what a user scanning it where it stands takes (the
    automatic masks' benchmark, `neuroom bench masks`). Views ring it as the isolated captures do, each
    eye kept inside the room; the mask is the object's id on it and 0 on the room. Returns the room.json
    entry of the object (its `capture_to_object` maps the room's world to the object's frame)."""
    cap = cfg["object_capture"]
    sc = reset_scene(threads)
    size = build_room(cfg["room"])
    lighting = add_lights(size, cfg["capture_lighting"], cfg["room"].get("windows", []))
    log = []
    ob, osize, _ = import_furniture(catalog, spec, workdir, log)
    ob.pass_index = oid
    rng = random.Random(f"{cfg['seed']}/{spec['name']}/in_room")
    placed = pose_matrix(size[0] / 2, size[1] / 2, osize[2] / 2, rng.uniform(-math.pi, math.pi))
    ob.matrix_world = placed
    cam, fl, ring = capture_camera(cap, osize)
    centre = Vector(placed.translation)
    passes = Passes(workdir)
    folder = os.path.join(out, "in_room", "captures", spec["name"])
    frames = []
    start = time.time()
    for k in range(IN_ROOM_VIEWS):
        eye, target = ring.view(k, IN_ROOM_VIEWS, rng)
        eye = [min(max(centre[i] + e, IN_ROOM_MARGIN_M), size[i] - IN_ROOM_MARGIN_M)
               for i, e in enumerate(eye)]
        cam.matrix_world = look_at(eye, centre + Vector(target))
        bpy.context.view_layer.update()
        name = f"{k:04d}"
        render_color(os.path.join(folder, "images", name + ".jpg"), cap["samples"], JPEG_QUALITY["capture"])
        depth, ids = passes.render()
        ids = np.where(ids == oid, oid, 0)
        frames.append(save_frame(folder, name, depth, ids, cam))
    write_capture_transforms(folder, cap["res"], fl, frames, lighting)
    print(f"[suite] {spec['name']} in the room: {round(time.time() - start, 1)} s", flush=True)
    return {"id": oid, "name": spec["name"], "category": spec["category"],
            "capture": "captures/" + spec["name"], "relations": relations(spec), "size": osize,
            "capture_to_object": matrix_rows(placed.inverted())}


def write_in_room(catalog, cfg, out, workdir, threads):
    """`OUT/in_room/`: a room whose objects were captured standing in it (one per distinct model), its
    background the room's own capture (`captures/background` links to it)."""
    objects = [capture_object_in_room(catalog, spec, oid, cfg, out, workdir, threads)
               for oid, spec in enumerate(cfg["objects"], start=1) if "instance_of" not in spec]
    # The background is the room's own capture, linked so that the folder holds every capture it names.
    link = os.path.join(out, "in_room", "captures", "background")
    if not os.path.islink(link):
        os.symlink(os.path.join("..", "..", "captures", "background"), link)
    write_json(os.path.join(out, "in_room", "room.json"), {
        "format": "neuroom.room/1", "name": cfg["name"] + "_in_room",
        "background": {"capture": "captures/background"}, "objects": objects,
        "room_box": {"min": [0, 0, 0], "max": cfg["room"]["size"]}})


def wall_distance(eye, direction, size):
    """Distance from `eye` along `direction` to the room's box."""
    best = float("inf")
    for i in range(3):
        if abs(direction[i]) > 1e-9:
            bound = size[i] if direction[i] > 0 else 0.0
            best = min(best, (bound - eye[i]) / direction[i])
    return best


# ----------------------------------------------------------------------------------------------
# Arrangements
# ----------------------------------------------------------------------------------------------


def footprint(pose_xy, yaw, size, margin=0.0):
    """Corners of an object's footprint (x forward, y left) at `pose_xy`, turned by `yaw`."""
    hx, hy = size[0] / 2 + margin, size[1] / 2 + margin
    c, s = math.cos(yaw), math.sin(yaw)
    return [(pose_xy[0] + c * x - s * y, pose_xy[1] + s * x + c * y)
            for x, y in ((hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy))]


def polygons_overlap(a, b):
    """Separating-axis test of two convex quadrilaterals."""
    for poly in (a, b):
        for i in range(4):
            p, q = poly[i], poly[(i + 1) % 4]
            axis = (q[1] - p[1], p[0] - q[0])
            pa = [axis[0] * x + axis[1] * y for x, y in a]
            pb = [axis[0] * x + axis[1] * y for x, y in b]
            if max(pa) < min(pb) or max(pb) < min(pa):
                return False
    return True


def inside_room(poly, size, margin=0.0):
    return all(margin <= x <= size[0] - margin and margin <= y <= size[1] - margin for x, y in poly)


def stands_in_fixed(poly, z, height, fixed):
    """Whether a footprint `poly` standing from `z - height / 2` to `z + height / 2` enters the fixed
    furniture box `fixed` (an axis-aligned `min`, `max`): a movable object may not stand inside the
    room's own furniture."""
    lo, hi = fixed["min"], fixed["max"]
    if z + height / 2 <= lo[2] or z - height / 2 >= hi[2]:
        return False
    box = [(lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1])]
    return polygons_overlap(poly, box)


def sample_arrangement(cfg, sizes, rng):
    """Poses for every object following its role ("wall", "floor", "on:<name>"), no two footprints
    overlapping (objects on a supporter only against their neighbours on it), and a camera at least
    `camera_clearance` metres from every footprint. Returns ({name: (x, y, z, yaw)}, camera (x, y, z, yaw))."""
    size = cfg["room"]["size"]
    objects = cfg["objects"]
    for _attempt in range(2000):
        poses, ok = {}, True
        for spec in objects:
            name, role, s = spec["name"], spec["role"], sizes[spec["name"]]
            placed = False
            for _try in range(200):
                if role == "wall":
                    wall = rng.choice(list(WALLS))
                    along, fixed, at_max, normal = WALLS[wall]
                    length = size[along]
                    t = rng.uniform(s[1] / 2 + 0.05, length - s[1] / 2 - 0.05)
                    xy = [0.0, 0.0]
                    xy[along] = t
                    xy[fixed] = size[fixed] - s[0] / 2 - 0.01 if at_max else s[0] / 2 + 0.01
                    yaw = math.atan2(normal[1], normal[0])
                    z = s[2] / 2
                elif role == "floor":
                    xy = [rng.uniform(0.2, size[0] - 0.2), rng.uniform(0.2, size[1] - 0.2)]
                    yaw = rng.uniform(-math.pi, math.pi)
                    z = s[2] / 2
                elif role.startswith("on:"):
                    base = role[3:]
                    bx, by, bz, byaw = poses[base]
                    bs = sizes[base]
                    room_x = max(bs[0] / 2 - max(s[0], s[1]) / 2 - 0.02, 0.0)
                    room_y = max(bs[1] / 2 - max(s[0], s[1]) / 2 - 0.02, 0.0)
                    lx, ly = rng.uniform(-room_x, room_x), rng.uniform(-room_y, room_y)
                    c, si = math.cos(byaw), math.sin(byaw)
                    xy = [bx + c * lx - si * ly, by + si * lx + c * ly]
                    yaw = rng.uniform(-math.pi, math.pi)
                    z = bz + bs[2] / 2 + s[2] / 2
                else:
                    sys.exit(f"object {name}: unknown role {role!r}")
                poly = footprint(xy, yaw, s)
                if not inside_room(poly, size, 0.0):
                    continue
                if any(stands_in_fixed(poly, z, s[2], f) for f in cfg["room"].get("fixed", [])):
                    continue
                clash = False
                for other, (ox, oy, oz, oyaw) in poses.items():
                    same_level = abs(oz - z) < (sizes[other][2] + s[2]) / 2
                    if same_level and polygons_overlap(poly, footprint((ox, oy), oyaw, sizes[other], 0.03)):
                        clash = True
                        break
                if not clash:
                    poses[name] = (xy[0], xy[1], z, yaw)
                    placed = True
                    break
            if not placed:
                ok = False
                break
        if not ok:
            continue
        clearance = cfg["panoramas"].get("camera_clearance", 0.5)
        for _try in range(500):
            cx, cy = rng.uniform(0.6, size[0] - 0.6), rng.uniform(0.6, size[1] - 0.6)
            around = footprint((cx, cy), 0.0, [0.01, 0.01, 0.0], clearance)
            near = any(polygons_overlap(around, footprint((ox, oy), oyaw, sizes[n]))
                       for n, (ox, oy, oz, oyaw) in poses.items())
            spot = footprint((cx, cy), 0.0, [0.01, 0.01, 0.0])
            near = near or any(stands_in_fixed(spot, 1.0, 2.0, f) for f in cfg["room"].get("fixed", []))
            if not near:
                h = rng.uniform(*cfg["panoramas"]["height"])
                return poses, (cx, cy, h, rng.uniform(-math.pi, math.pi))
    sys.exit("could not place every object; make the room larger or the objects fewer")


def pose_matrix(x, y, z, yaw):
    return Matrix.Translation(Vector((x, y, z))) @ Matrix.Rotation(yaw, 4, "Z")


def render_panoramas(catalog, cfg, sizes, out, workdir, threads, only=None):
    """Every arrangement under every panorama lighting: colour, ray depth, instance mask and truth."""
    pano = cfg["panoramas"]
    rng = random.Random(f"{cfg['seed']}/arrangements")
    arrangements = [sample_arrangement(cfg, sizes, rng) for _ in range(pano["arrangements"])]
    report = {}
    for a, (poses, camera) in enumerate(arrangements):
        for j, lighting in enumerate(cfg["panorama_lightings"]):
            if lighting.get("arrangements") is not None and a not in lighting["arrangements"]:
                continue
            stem = f"{cfg['name']}_a{a}_l{j}"
            if only is not None and stem not in only:
                continue
            start = time.time()
            sc = reset_scene(threads)
            size = build_room(cfg["room"])
            described = add_lights(size, lighting, cfg["room"].get("windows", []))
            sc.view_settings.exposure = lighting.get("exposure_ev", 0.0)
            objects = []
            for oid, spec in enumerate(cfg["objects"], start=1):
                log = []
                ob, _, _ = import_furniture(catalog, spec_for_import(cfg, spec), workdir, log)
                ob.pass_index = oid
                ob.matrix_world = pose_matrix(*poses[spec["name"]])
                objects.append({"id": oid, "name": spec["name"],
                                "object_to_world": matrix_rows(ob.matrix_world)})
            sc.render.resolution_x, sc.render.resolution_y = pano["w"], pano["h"]
            cam = camera_object(pano=True)
            cx, cy, cz, cyaw = camera
            camera_to_world = pose_matrix(cx, cy, cz, cyaw)
            cam.matrix_world = camera_to_world @ PANORAMA_FROM_CAMERA.inverted()
            bpy.context.view_layer.update()
            folder = os.path.join(out, "panoramas")
            render_color(os.path.join(folder, stem + ".jpg"), pano["samples"], JPEG_QUALITY["panorama"])
            passes = Passes(workdir)
            depth, ids = passes.render()
            save_depth_mask(depth, ids, os.path.join(folder, stem + ".depth.png"),
                            os.path.join(folder, stem + ".mask.png"))
            write_json(os.path.join(folder, stem + ".json"), {
                "format": "neuroom.arrangement/1", "image": stem + ".jpg",
                "camera_to_world": matrix_rows(camera_to_world), "objects": objects, "lighting": described})
            report[stem] = {"render_seconds": round(time.time() - start, 1), "samples": pano["samples"],
                            "w": pano["w"], "h": pano["h"]}
            print(f"[suite] {stem}: {report[stem]['render_seconds']} s", flush=True)
    return report


def spec_for_import(cfg, spec):
    """The catalog spec an object is imported from: its own, or that of the object whose capture it
    shares (an identical instance)."""
    if "instance_of" in spec:
        return dict(next(o for o in cfg["objects"] if o["name"] == spec["instance_of"]), name=spec["name"])
    return spec


# ----------------------------------------------------------------------------------------------
# The room
# ----------------------------------------------------------------------------------------------


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    parser = argparse.ArgumentParser(prog="make_room.py")
    parser.add_argument("--config", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--catalog", default=CATALOG_DIR)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--only", nargs="*", help="render only these panoramas (stems); the rest is kept")
    parser.add_argument("--objects-in-room", action="store_true",
                        help="render only OUT/in_room/: every object captured standing in the room")
    args = parser.parse_args(argv)
    with open(args.config) as f:
        cfg = json.load(f)
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    catalog = Catalog(args.catalog)
    workdir = tempfile.mkdtemp(prefix="neuroom-suite-")
    if args.objects_in_room:
        write_in_room(catalog, cfg, out, workdir, args.threads)
        shutil.rmtree(workdir, ignore_errors=True)
        return
    meta_path = os.path.join(out, "meta", "generation.json")
    meta = {"objects": {}, "config": cfg, "blender": bpy.app.version_string}
    if os.path.exists(meta_path):
        with open(meta_path) as f:
            meta.update({k: v for k, v in json.load(f).items() if k != "config"})
    sizes = {}
    room_objects = []
    for oid, spec in enumerate(cfg["objects"], start=1):
        capture = spec.get("instance_of", spec["name"])
        entry = {"id": oid, "name": spec["name"], "category": spec["category"],
                 "capture": "captures/" + capture, "relations": relations(spec)}
        if "instance_of" in spec:
            sizes[spec["name"]] = sizes[capture]
            shutil.copyfile(os.path.join(out, "meshes", capture + ".ply"),
                            os.path.join(out, "meshes", spec["name"] + ".ply"))
        else:
            done = os.path.join(out, "captures", capture, "transforms.json")
            if args.only is not None and os.path.exists(done) and capture in meta["objects"]:
                sizes[capture] = meta["objects"][capture]["size"]
            else:
                sizes[capture], meta["objects"][capture] = capture_object(
                    catalog, spec, oid, cfg, out, workdir, args.threads)
                print(f"[suite] {capture}: {meta['objects'][capture]['render_seconds']} s", flush=True)
        entry["size"] = sizes[spec["name"]]
        room_objects.append(entry)
    size = cfg["room"]["size"]
    write_json(os.path.join(out, "room.json"), {
        "format": "neuroom.room/1", "name": cfg["name"], "background": {"capture": "captures/background"},
        "objects": room_objects, "room_box": {"min": [0, 0, 0], "max": size}})
    if args.only is None or "background" not in meta:
        meta["background"] = capture_background(cfg, out, workdir, args.threads)
        print(f"[suite] background: {meta['background']['render_seconds']} s", flush=True)
    meta.setdefault("panoramas", {}).update(
        render_panoramas(catalog, cfg, sizes, out, workdir, args.threads, args.only))
    write_json(meta_path, meta)
    shutil.rmtree(workdir, ignore_errors=True)


def relations(spec):
    role = spec["role"]
    if role == "wall":
        return ["floor", "wall"]
    if role == "floor":
        return ["floor"]
    return [role]


if __name__ == "__main__":
    main()
