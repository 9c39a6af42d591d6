#!/usr/bin/env python3
"""Writes the generated part of neuroom-core's bad-input corpus and the tiny valid room the tests corrupt.

    python3 tools/make_corpus.py

Outputs (committed; rerun after changing this script):
  crates/neuroom-core/tests/corpus/gen_*       malformed or unusual files, one problem each
  crates/neuroom-core/tests/rooms/tiny/        a complete, valid room of a few tiny files (docs/formats.md)

PNG, Radiance HDR, OpenEXR and PLY files are written with the standard library only; the JPEG files need
Pillow. Every file is deterministic.
"""

import io
import json
import math
import os
import struct
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CORPUS = os.path.join(ROOT, "crates/neuroom-core/tests/corpus")
TINY = os.path.join(ROOT, "crates/neuroom-core/tests/rooms/tiny")


def write(path, data):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    mode = "wb" if isinstance(data, bytes) else "w"
    with open(path, mode) as f:
        f.write(data)


def chunk(kind, body):
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def png(width, height, color_type, bit_depth, rows, palette=None):
    """A PNG from raw rows (bytes each, without filter byte)."""
    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0, 0)
    raw = b"".join(b"\x00" + r for r in rows)
    out = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr)
    if palette is not None:
        out += chunk(b"PLTE", palette)
    return out + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


def rgb8(width, height, f):
    return png(width, height, 2, 8, [bytes(c for u in range(width) for c in f(u, v)) for v in range(height)])


def gray16(width, height, f):
    return png(width, height, 0, 16, [b"".join(struct.pack(">H", f(u, v)) for u in range(width)) for v in range(height)])


def gray8(width, height, f):
    return png(width, height, 0, 8, [bytes(f(u, v) for u in range(width)) for v in range(height)])


def hdr(width, height, header_size=None, rows=None):
    """A flat (not run-length encoded) Radiance RGBE file; `header_size` overrides the size line."""
    w, h = header_size or (width, height)
    head = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (h, w)
    rows = height if rows is None else rows
    return head + bytes([128, 64, 32, 129]) * (width * rows)


def exr(width, height, channels="BGR", pixel=lambda u, v, c: 0.5):
    """An uncompressed scanline OpenEXR file with float channels (names in alphabetical order)."""

    def attr(name, kind, value):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value

    chlist = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in channels) + b"\0"
    box = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = (
        attr("channels", "chlist", chlist)
        + attr("compression", "compression", b"\0")
        + attr("dataWindow", "box2i", box)
        + attr("displayWindow", "box2i", box)
        + attr("lineOrder", "lineOrder", b"\0")
        + attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
        + attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0))
        + attr("screenWindowWidth", "float", struct.pack("<f", 1.0))
        + b"\0"
    )
    start = 8 + len(header) + 8 * height
    lines, offsets = b"", []
    for v in range(height):
        data = b"".join(struct.pack("<f", pixel(u, v, c)) for c in channels for u in range(width))
        offsets.append(start + len(lines))
        lines += struct.pack("<ii", v, len(data)) + data
    return b"\x76\x2f\x31\x01" + struct.pack("<i", 2) + header + b"".join(struct.pack("<Q", o) for o in offsets) + lines


def jpeg(mode, size, colour):
    from PIL import Image

    buf = io.BytesIO()
    Image.new(mode, size, colour).save(buf, "JPEG", quality=90)
    return buf.getvalue()


def set_jpeg_size(data, width, height):
    """Rewrites the frame header (SOF0/SOF2) of a JPEG to claim another size."""
    i = 2
    while i < len(data):
        marker, length = data[i + 1], struct.unpack(">H", data[i + 2 : i + 4])[0]
        if marker in (0xC0, 0xC1, 0xC2):
            return data[: i + 5] + struct.pack(">HH", height, width) + data[i + 9 :]
        i += 2 + length
    raise ValueError("no frame header")


def corpus():
    c = lambda name, data: write(os.path.join(CORPUS, "gen_" + name), data)
    # Colour images a reader converts (and says so).
    c("gray8.png", gray8(8, 4, lambda u, v: 40 * v))
    c("rgb16.png", png(8, 4, 2, 16, [b"\x12\x34" * 24] * 4))
    c("palette.png", png(8, 4, 3, 8, [bytes([u % 2 for u in range(8)])] * 4, palette=b"\xff\x00\x00\x00\x00\xff"))
    c("gray_alpha.png", png(8, 4, 4, 8, [b"\x80\xff" * 8] * 4))
    c("cmyk.jpg", jpeg("CMYK", (16, 8), (0, 255, 255, 0)))
    c("gray.jpg", jpeg("L", (16, 8), 128))
    # Broken or forged images.
    good_jpeg = jpeg("RGB", (64, 32), (200, 30, 30))
    c("truncated.jpg", good_jpeg[: len(good_jpeg) // 3])
    c("huge.jpg", set_jpeg_size(good_jpeg, 20000, 8))
    c("bomb.jpg", set_jpeg_size(good_jpeg, 16000, 16000))
    c("bomb.png", png(16000, 16000, 2, 8, [b"\0" * 48]))
    good_png = rgb8(8, 4, lambda u, v: (u * 30, v * 60, 90))
    c("bad_crc.png", good_png[:29] + bytes([good_png[29] ^ 0xFF]) + good_png[30:])
    c("zero_width.png", png(0, 4, 2, 8, [b""] * 4))
    c("depth_rgb16.png", png(8, 4, 2, 16, [b"\x01\x00" * 24] * 4))
    c("depth_no_idat.png", good_png[: good_png.index(b"IDAT") - 4] + chunk(b"IEND", b""))
    c("mask_palette.png", png(8, 4, 3, 8, [bytes(8)] * 4, palette=b"\x00\x00\x00"))
    # Environment maps.
    c("envmap_square.hdr", hdr(8, 8))
    c("envmap_truncated.hdr", hdr(8, 4, rows=2))
    c("envmap_huge.hdr", hdr(8, 4, header_size=(40000, 20000)))
    c("envmap_tall.hdr", hdr(8, 4, header_size=(16000, 8000)))
    c("envmap_nan.exr", exr(8, 4, pixel=lambda u, v, ch: float("nan") if (u, v) == (3, 2) else 1.0))
    c("envmap_no_blue.exr", exr(8, 4, channels="GR"))
    c("envmap_square.exr", exr(4, 4))
    whole = exr(8, 4)
    c("envmap_truncated.exr", whole[: len(whole) - 40])
    # PLY meshes.
    head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
    faces = "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
    c("ply_no_magic.ply", "mesh\n" + head[4:] + faces)
    c("ply_no_end_header.ply", head)
    c("ply_bad_index.ply", head + faces + "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")
    c("ply_fractional_index.ply", head + faces + "0 0 0\n1 0 0\n0 1 0\n3 0 1 1.5\n")
    c("ply_nan_vertex.ply", head + faces + "0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n")
    c("ply_ends_early.ply", head + faces + "0 0 0\n1 0 0\n")
    c("ply_bad_count.ply", head.replace("vertex 3", "vertex -3") + faces)
    c("ply_big_endian.ply", head.replace("ascii", "binary_big_endian") + faces)
    c("ply_unknown_type.ply", head.replace("float z", "quad z") + faces)
    binary = head.replace("ascii", "binary_little_endian") + faces
    c("ply_truncated_binary.ply", binary.encode() + struct.pack("<fff", 0, 0, 0) + b"\x03\x00")
    binary_ok = binary.replace("property float z\n", "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n")
    c("ply_binary_coloured.ply", binary_ok.encode() + b"".join(struct.pack("<fffBBB", x, y, 0, 255, 0, 0) for x, y in [(0, 0), (1, 0), (0, 1)]) + struct.pack("<Biii", 3, 0, 1, 2))
    c("ply_endless_element.ply", "ply\nformat ascii 1.0\nelement nothing 999999999999999\nend_header\n")
    # JSON.
    c("empty.json", "")
    c("whitespace.json", "  \n\t\n")
    c("not_utf8.json", b'{"format": "neuroom.room/1", "name": "\xff\xfe"}')
    c("deep_nesting.json", "[" * 1000 + "]" * 1000)
    c("huge_number.json", '{"format": "neuroom.room/1", "name": "r", "background": {"capture": "b"}, '
      '"objects": [{"id": 1, "name": "a", "category": "c", "capture": "a", "size": [1e400, 1, 1]}]}')
    pose = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    frame = {"file_path": "images/0.png", "transform_matrix": pose}
    capture = {"fl_x": 10, "fl_y": 10, "cx": 4, "cy": 3, "w": 8, "h": 6, "frames": [frame]}
    c("transforms_nan.json", json.dumps(capture).replace('"fl_x": 10', '"fl_x": NaN'))
    c("transforms_too_wide.json", json.dumps(dict(capture, w=20000)))
    c("transforms_no_file_path.json", json.dumps(dict(capture, frames=[{"transform_matrix": pose}])))
    arrangement = {"format": "neuroom.arrangement/1", "image": "p.png", "camera_to_world": pose,
                   "objects": [{"id": 1, "name": "a", "object_to_world": pose},
                               {"id": 1, "name": "b", "object_to_world": pose}]}
    c("arrangement_duplicate_id.json", json.dumps(arrangement))
    c("arrangement_nan.json", json.dumps(arrangement).replace('"camera_to_world": [[1', '"camera_to_world": [[NaN'))
    c("arrangement_skewed.json", json.dumps(dict(arrangement, objects=[],
                                                 camera_to_world=[[1, 0.2, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])))


# The tiny room: one object (a 0.4 m box, id 1) captured in two 8×6 views, an empty-room capture of two
# views, and one 16×8 panorama with its arrangement, depth and mask.
W, H = 8, 6


def look_pose(eye):
    """Camera-to-world looking at the origin from `eye` (OpenGL frame: looks along −z, +y up)."""
    f = [-x for x in eye]
    n = math.sqrt(sum(x * x for x in f))
    f = [x / n for x in f]
    r = [f[1], -f[0], 0.0]
    n = math.sqrt(sum(x * x for x in r))
    r = [x / n for x in r]
    u = [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]]
    return [[r[i], u[i], -f[i], eye[i]] for i in range(3)] + [[0, 0, 0, 1]]


def capture(name, ids):
    d = os.path.join(TINY, "captures", name)
    frames = []
    for k, eye in enumerate([(2.0, 0.0, 1.0), (0.0, 2.0, 1.0)]):
        write(os.path.join(d, f"images/{k}.png"), rgb8(W, H, lambda u, v: (20 * u, 30 * v, 100 + 50 * k)))
        write(os.path.join(d, f"depths/{k}.png"), gray16(W, H, lambda u, v: 2000 + 10 * u))
        write(os.path.join(d, f"masks/{k}.png"), gray8(W, H, lambda u, v: ids if 2 <= u < 6 else 0))
        frames.append({"file_path": f"images/{k}.png", "depth_file_path": f"depths/{k}.png",
                       "instance_file_path": f"masks/{k}.png", "transform_matrix": look_pose(eye)})
    t = {"camera_model": "OPENCV", "fl_x": 8.0, "fl_y": 8.0, "cx": 4.0, "cy": 3.0, "w": W, "h": H,
         "depth_unit_scale_factor": 0.001, "frames": frames}
    write(os.path.join(d, "transforms.json"), json.dumps(t, indent=1) + "\n")


def tiny_room():
    room = {"format": "neuroom.room/1", "name": "tiny", "background": {"capture": "captures/background"},
            "objects": [{"id": 1, "name": "box", "category": "box", "capture": "captures/box",
                         "size": [0.4, 0.4, 0.4], "relations": ["floor"]}]}
    write(os.path.join(TINY, "room.json"), json.dumps(room, indent=1) + "\n")
    capture("background", 0)
    capture("box", 1)
    p = os.path.join(TINY, "panoramas")
    write(os.path.join(p, "p0.png"), rgb8(16, 8, lambda u, v: (10 * u, 20 * v, 80)))
    write(os.path.join(p, "p0.depth.png"), gray16(16, 8, lambda u, v: 1500))
    write(os.path.join(p, "p0.mask.png"), gray8(16, 8, lambda u, v: 1 if (u, v) == (8, 5) else 0))
    pose = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 1.5], [0, 0, 0, 1]]
    box = [[1, 0, 0, 1], [0, 1, 0, 0], [0, 0, 1, 0.2], [0, 0, 0, 1]]
    arrangement = {"format": "neuroom.arrangement/1", "image": "p0.png", "camera_to_world": pose,
                   "objects": [{"id": 1, "name": "box", "object_to_world": box}]}
    write(os.path.join(p, "p0.json"), json.dumps(arrangement, indent=1) + "\n")
    corners = [(x, y, z) for x in (-0.2, 0.2) for y in (-0.2, 0.2) for z in (-0.2, 0.2)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    ply = "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
    ply += "element face 6\nproperty list uchar int vertex_indices\nend_header\n"
    ply += "".join("%g %g %g\n" % c for c in corners) + "".join("4 %d %d %d %d\n" % q for q in quads)
    write(os.path.join(TINY, "meshes/box.ply"), ply)


if __name__ == "__main__":
    corpus()
    tiny_room()
