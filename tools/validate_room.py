#!/usr/bin/env python3
"""Independent validator for neuroom rooms (docs/formats.md).

Standard library only (json, zlib, struct, math): it shares no code with the Rust project, so a writer and
a reader that agree with each other cannot hide a convention error from it.

    python3 tools/validate_room.py ROOM [--max-frames N] [--stride S] [--quiet]

Prints one line per problem ("ERROR <file>: <field>: <message>"), warnings ("WARN ...") that do not fail
the room, measured figures ("INFO ..."), and a summary. Exit status: 0 valid, 1 problems, 2 usage error.
"""

import json
import math
import os
import struct
import sys
import zlib
from array import array

# --------------------------------------------------------------------------------------------------
# Tolerances (metres unless stated)

RIGID_TOL = 1e-3          # |RᵀR − I| and |det − 1|
REPROJ_MEDIAN_MAX = 0.01  # median |depth error| of a reprojected view
REPROJ_MEDIAN_WARN = 0.003
BOX_MARGIN_CAPTURE = 0.01 # object-capture points vs the object's box
BOX_MARGIN_PANO = 0.02    # panorama points vs the oriented boxes
BOX_INSIDE_MIN = 0.99     # fraction of object pixels that must fall in the box
PANO_BG_INSIDE_MAX = 0.05 # fraction of id-0 panorama pixels allowed deep inside some box
FLOOR_TOL = 0.02          # box bottom vs z = 0 for "floor" objects
ON_TOL = 0.03             # box bottom vs supporter's top for "on:<name>" objects
MESH_SIZE_TOL = 0.03      # relative bounding-box extent error of a GT mesh
OVERLAP_MAX = 0.25        # box interpenetration, fraction of the smaller box's volume
ALPHA_DISAGREE_MAX = 0.02  # surface pixels (mask id or depth) with alpha 0; any is a warning
MESH_CUTOFF = 0.01        # distances to the GT mesh are measured up to this
MESH_MEDIAN_MAX = 0.003   # median distance of object pixels to their GT mesh (blender-lite README: 1–2.5 mm)
MESH_MEDIAN_WARN = 0.001


class Report:
    def __init__(self, room, quiet=False):
        self.room = room
        self.quiet = quiet
        self.problems = []
        self.warnings = []
        self.infos = []

    def _rel(self, path):
        try:
            return os.path.relpath(path, self.room)
        except ValueError:
            return path

    def error(self, path, field, msg):
        line = f"ERROR {self._rel(path)}: {field}: {msg}"
        self.problems.append(line)
        print(line, flush=True)

    def warn(self, path, field, msg):
        line = f"WARN  {self._rel(path)}: {field}: {msg}"
        self.warnings.append(line)
        print(line, flush=True)

    def info(self, path, msg):
        line = f"INFO  {self._rel(path)}: {msg}"
        self.infos.append(line)
        if not self.quiet:
            print(line, flush=True)


# --------------------------------------------------------------------------------------------------
# PNG / JPEG

class ImageError(Exception):
    pass


PNG_SIG = b"\x89PNG\r\n\x1a\n"
PNG_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}
PNG_DEPTHS = {0: (1, 2, 4, 8, 16), 2: (8, 16), 3: (1, 2, 4, 8), 4: (8, 16), 6: (8, 16)}


def image_header(path):
    """(kind, width, height, bit_depth, color_type or jpeg components) from the file header."""
    with open(path, "rb") as f:
        head = f.read(64)
        if head.startswith(PNG_SIG):
            if head[12:16] != b"IHDR":
                raise ImageError("PNG without IHDR first")
            w, h, bd, ct, _cm, _fm, il = struct.unpack(">IIBBBBB", head[16:29])
            return ("png", w, h, bd, ct)
        if head.startswith(b"\xff\xd8"):
            f.seek(2)
            while True:
                b = f.read(1)
                if not b:
                    raise ImageError("JPEG without a frame header")
                if b != b"\xff":
                    continue
                m = f.read(1)
                while m == b"\xff":
                    m = f.read(1)
                if not m:
                    raise ImageError("truncated JPEG")
                mk = m[0]
                if mk in (0xD8, 0x01) or 0xD0 <= mk <= 0xD7:
                    continue
                seg = f.read(2)
                if len(seg) < 2:
                    raise ImageError("truncated JPEG")
                (ln,) = struct.unpack(">H", seg)
                if mk in (0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF):
                    d = f.read(ln - 2)
                    bd, h, w, nc = struct.unpack(">BHHB", d[:6])
                    return ("jpeg", w, h, bd, nc)
                f.seek(ln - 2, 1)
        raise ImageError("neither PNG nor JPEG")


class Png:
    """A decoded PNG: width, height, channels (after palette expansion), bit depth (8 or 16 after
    expansion), samples (flat, row-major, interleaved), has_alpha."""

    __slots__ = ("width", "height", "channels", "bit_depth", "samples", "has_alpha", "color_type")

    def channel(self, c):
        return self.samples[c:: self.channels]

    def alpha(self):
        if not self.has_alpha:
            return None
        return self.samples[self.channels - 1:: self.channels]


def _unfilter(raw, pos, width_px, height, bpp_bits, channels_bytes_pp, out, out_pos):
    """Undo PNG filters for one (sub)image; returns new raw position and out position."""
    stride = (width_px * bpp_bits + 7) // 8
    bpp = max(1, channels_bytes_pp)
    prev = bytearray(stride)
    for _y in range(height):
        if pos + 1 + stride > len(raw):
            raise ImageError("image data too short")
        ft = raw[pos]
        line = bytearray(raw[pos + 1: pos + 1 + stride])
        pos += 1 + stride
        if ft == 0:
            pass
        elif ft == 1:
            for i in range(bpp, stride):
                line[i] = (line[i] + line[i - bpp]) & 255
        elif ft == 2:
            line = bytearray([(a + b) & 255 for a, b in zip(line, prev)])
        elif ft == 3:
            for i in range(min(bpp, stride)):
                line[i] = (line[i] + (prev[i] >> 1)) & 255
            for i in range(bpp, stride):
                line[i] = (line[i] + ((line[i - bpp] + prev[i]) >> 1)) & 255
        elif ft == 4:
            for i in range(min(bpp, stride)):
                line[i] = (line[i] + prev[i]) & 255
            for i in range(bpp, stride):
                a = line[i - bpp]
                b = prev[i]
                c = prev[i - bpp]
                p = a + b - c
                pa = p - a if p > a else a - p
                pb = p - b if p > b else b - p
                pc = p - c if p > c else c - p
                if pa <= pb and pa <= pc:
                    pr = a
                elif pb <= pc:
                    pr = b
                else:
                    pr = c
                line[i] = (line[i] + pr) & 255
        else:
            raise ImageError(f"unknown filter type {ft}")
        out[out_pos: out_pos + stride] = line
        out_pos += stride
        prev = line
    return pos, out_pos


def _unpack_bits(data, width, height, bd):
    """Expands 1/2/4-bit rows to one byte per sample (rows are byte aligned)."""
    stride = (width * bd + 7) // 8
    per = 8 // bd
    mask = (1 << bd) - 1
    out = bytearray(width * height)
    k = 0
    for y in range(height):
        row = data[y * stride:(y + 1) * stride]
        for x in range(width):
            byte = row[x // per]
            shift = 8 - bd * (x % per + 1)
            out[k] = (byte >> shift) & mask
            k += 1
    return out


def decode_png(path):
    with open(path, "rb") as f:
        data = f.read()
    if not data.startswith(PNG_SIG):
        raise ImageError("not a PNG file")
    pos = 8
    ihdr = None
    idat = []
    palette = None
    trns = None
    while pos < len(data):
        if pos + 8 > len(data):
            raise ImageError("truncated chunk header")
        (ln,) = struct.unpack(">I", data[pos: pos + 4])
        ctype = data[pos + 4: pos + 8]
        body = data[pos + 8: pos + 8 + ln]
        if len(body) != ln or pos + 12 + ln > len(data):
            raise ImageError(f"truncated chunk {ctype!r}")
        (crc,) = struct.unpack(">I", data[pos + 8 + ln: pos + 12 + ln])
        if zlib.crc32(ctype + body) & 0xFFFFFFFF != crc:
            raise ImageError(f"CRC mismatch in chunk {ctype.decode('latin-1')}")
        pos += 12 + ln
        if ctype == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif ctype == b"PLTE":
            palette = body
        elif ctype == b"tRNS":
            trns = body
        elif ctype == b"IDAT":
            idat.append(body)
        elif ctype == b"IEND":
            break
    if ihdr is None:
        raise ImageError("no IHDR chunk")
    w, h, bd, ct, cm, fm, il = ihdr
    if ct not in PNG_CHANNELS or bd not in PNG_DEPTHS[ct]:
        raise ImageError(f"invalid colour type {ct} / bit depth {bd}")
    if cm != 0 or fm != 0 or il not in (0, 1):
        raise ImageError("invalid compression/filter/interlace method")
    if w == 0 or h == 0:
        raise ImageError("zero size")
    if not idat:
        raise ImageError("no IDAT chunk")
    try:
        raw = zlib.decompress(b"".join(idat))
    except zlib.error as e:
        raise ImageError(f"zlib: {e}")
    nch = PNG_CHANNELS[ct]
    bits_pp = nch * bd
    bytes_pp = (bits_pp + 7) // 8
    row_bytes = (w * bits_pp + 7) // 8
    if il == 0:
        buf = bytearray(row_bytes * h)
        _unfilter(raw, 0, w, h, bits_pp, bytes_pp, buf, 0)
        if bd < 8:
            buf = _unpack_bits(buf, w, h, bd)
    else:
        # Adam7: decode each pass, scatter into the full image (one sample per byte for bd < 8).
        sample_bytes = 1 if bd < 8 else nch * bd // 8
        buf = bytearray(w * h * sample_bytes)
        passes = [(0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2), (0, 1, 1, 2)]
        rp = 0
        for x0, y0, dx, dy in passes:
            pw = (w - x0 + dx - 1) // dx
            ph = (h - y0 + dy - 1) // dy
            if pw <= 0 or ph <= 0:
                continue
            prow = (pw * bits_pp + 7) // 8
            pbuf = bytearray(prow * ph)
            rp, _ = _unfilter(raw, rp, pw, ph, bits_pp, bytes_pp, pbuf, 0)
            if bd < 8:
                pbuf = _unpack_bits(pbuf, pw, ph, bd)
            for j in range(ph):
                y = y0 + j * dy
                for i in range(pw):
                    x = x0 + i * dx
                    s = (j * pw + i) * sample_bytes
                    d = (y * w + x) * sample_bytes
                    buf[d: d + sample_bytes] = pbuf[s: s + sample_bytes]
    img = Png()
    img.width, img.height, img.color_type = w, h, ct
    if bd == 16:
        arr = array("H")
        arr.frombytes(bytes(buf))
        if sys.byteorder == "little":
            arr.byteswap()
        samples = arr
    else:
        samples = buf
    has_alpha = ct in (4, 6)
    channels = nch
    out_bd = 16 if bd == 16 else 8
    if ct == 3:
        if palette is None or len(palette) % 3:
            raise ImageError("palette image without a valid PLTE")
        n = len(palette) // 3
        alphas = bytearray([255] * n)
        if trns:
            alphas[: min(n, len(trns))] = trns[:n]
            has_alpha = True
        channels = 4 if has_alpha else 3
        out = bytearray(w * h * channels)
        k = 0
        for idx in samples:
            if idx >= n:
                raise ImageError(f"palette index {idx} out of range")
            out[k: k + 3] = palette[3 * idx: 3 * idx + 3]
            if has_alpha:
                out[k + 3] = alphas[idx]
            k += channels
        samples = out
    elif ct in (0, 2) and trns and bd >= 8:
        # A colour key: treat as alpha (only used for "no surface" checks).
        key = struct.unpack(">" + "H" * (len(trns) // 2), trns)
        maxv = 65535 if bd == 16 else 255
        out = array("H" if bd == 16 else "B")
        for p in range(w * h):
            px = samples[p * nch:(p + 1) * nch]
            out.extend(px)
            out.append(0 if tuple(px) == tuple(key[:nch]) else maxv)
        samples = out
        channels = nch + 1
        has_alpha = True
    elif bd < 8 and ct == 0:
        scale = 255 // ((1 << bd) - 1)
        samples = bytearray(v * scale for v in samples)
    img.channels = channels
    img.bit_depth = out_bd
    img.samples = samples
    img.has_alpha = has_alpha
    if len(samples) != w * h * channels:
        raise ImageError("decoded size mismatch")
    return img


# --------------------------------------------------------------------------------------------------
# Small linear algebra on 4×4 row-major lists

def is_number(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def check_pose(rep, path, field, m):
    """Returns the matrix (list of 4 lists) if it is a proper rigid transform, else reports and None."""
    if not (isinstance(m, list) and len(m) == 4 and all(isinstance(r, list) and len(r) == 4 for r in m)):
        rep.error(path, field, "must be 4 rows of 4 numbers")
        return None
    if not all(is_number(x) for r in m for x in r):
        rep.error(path, field, "entries must be finite numbers")
        return None
    bad = False
    if any(abs(m[3][i] - (0, 0, 0, 1)[i]) > 1e-9 for i in range(4)):
        rep.error(path, field, f"last row must be [0, 0, 0, 1], got {m[3]}")
        bad = True
    R = [r[:3] for r in m[:3]]
    worst = 0.0
    for i in range(3):
        for j in range(3):
            d = sum(R[k][i] * R[k][j] for k in range(3)) - (1.0 if i == j else 0.0)
            worst = max(worst, abs(d))
    det = (R[0][0] * (R[1][1] * R[2][2] - R[1][2] * R[2][1])
           - R[0][1] * (R[1][0] * R[2][2] - R[1][2] * R[2][0])
           + R[0][2] * (R[1][0] * R[2][1] - R[1][1] * R[2][0]))
    if worst > RIGID_TOL:
        rep.error(path, field, f"rotation not orthonormal (max |RᵀR − I| = {worst:.2g}; scale is not allowed)")
        bad = True
    elif det < 0:
        rep.error(path, field, f"rotation is a reflection (det = {det:.4f}, must be +1)")
        bad = True
    elif abs(det - 1) > RIGID_TOL:
        rep.error(path, field, f"det = {det:.6f}, must be +1")
        bad = True
    return None if bad else [list(map(float, r)) for r in m]


def mat_inv_rigid(m):
    R = [r[:3] for r in m[:3]]
    t = [m[0][3], m[1][3], m[2][3]]
    Rt = [[R[j][i] for j in range(3)] for i in range(3)]
    ti = [-(Rt[i][0] * t[0] + Rt[i][1] * t[1] + Rt[i][2] * t[2]) for i in range(3)]
    return [Rt[0] + [ti[0]], Rt[1] + [ti[1]], Rt[2] + [ti[2]], [0.0, 0.0, 0.0, 1.0]]


def mat_mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def transform(m, p):
    x, y, z = p
    return (m[0][0] * x + m[0][1] * y + m[0][2] * z + m[0][3],
            m[1][0] * x + m[1][1] * y + m[1][2] * z + m[1][3],
            m[2][0] * x + m[2][1] * y + m[2][2] * z + m[2][3])


def median(xs):
    if not xs:
        return float("nan")
    s = sorted(xs)
    n = len(s)
    return s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2])


def load_json(rep, path):
    try:
        with open(path, "r", encoding="utf-8") as f:
            return json.load(f)
    except FileNotFoundError:
        rep.error(path, "file", "missing")
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        rep.error(path, "file", f"not valid JSON: {e}")
    return None


def box_corners(size, m):
    hx, hy, hz = size[0] / 2, size[1] / 2, size[2] / 2
    return [transform(m, (sx * hx, sy * hy, sz * hz)) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]


def box_overlap_fraction(size_a, m_a, size_b, m_b, n=12):
    """Fraction of box A's volume inside box B (grid of n³ cell centres)."""
    to_b = mat_mul(mat_inv_rigid(m_b), m_a)
    hb = [s / 2 for s in size_b]
    inside = 0
    for i in range(n):
        x = (-0.5 + (i + 0.5) / n) * size_a[0]
        for j in range(n):
            y = (-0.5 + (j + 0.5) / n) * size_a[1]
            for k in range(n):
                z = (-0.5 + (k + 0.5) / n) * size_a[2]
                q = transform(to_b, (x, y, z))
                if abs(q[0]) <= hb[0] and abs(q[1]) <= hb[1] and abs(q[2]) <= hb[2]:
                    inside += 1
    return inside / n ** 3


# --------------------------------------------------------------------------------------------------
# room.json

def check_room_json(rep, room):
    path = os.path.join(room, "room.json")
    doc = load_json(rep, path)
    if doc is None:
        return None
    if not isinstance(doc, dict):
        rep.error(path, "(root)", "must be a JSON object")
        return None
    if doc.get("format") != "neuroom.room/1":
        rep.error(path, "format", f"must be \"neuroom.room/1\", got {doc.get('format')!r}")
    if not isinstance(doc.get("name"), str) or not doc.get("name"):
        rep.error(path, "name", "must be a non-empty string")
    bg = doc.get("background")
    bg_capture = None
    if not isinstance(bg, dict) or not isinstance(bg.get("capture"), str):
        rep.error(path, "background.capture", "missing or not a string")
    else:
        bg_capture = bg["capture"]
        if not os.path.isfile(os.path.join(room, bg_capture, "transforms.json")):
            rep.error(path, "background.capture", f"{bg_capture!r} has no transforms.json")
    objs = doc.get("objects")
    objects = []
    if not isinstance(objs, list):
        rep.error(path, "objects", "missing or not a list")
        objs = []
    ids, names = set(), set()
    for i, o in enumerate(objs):
        f = f"objects[{i}]"
        if not isinstance(o, dict):
            rep.error(path, f, "must be an object")
            continue
        ok = True
        oid = o.get("id")
        if not (isinstance(oid, int) and not isinstance(oid, bool)) or not 1 <= oid <= 65535:
            rep.error(path, f + ".id", f"must be an integer in 1..65535, got {oid!r}")
            ok = False
        elif oid in ids:
            rep.error(path, f + ".id", f"duplicate id {oid}")
            ok = False
        else:
            ids.add(oid)
        name = o.get("name")
        if not isinstance(name, str) or not name:
            rep.error(path, f + ".name", "must be a non-empty string")
            ok = False
        elif name in names:
            rep.error(path, f + ".name", f"duplicate name {name!r}")
            ok = False
        else:
            names.add(name)
        if "category" in o and not isinstance(o["category"], str):
            rep.error(path, f + ".category", "must be a string")
        size = o.get("size")
        if not (isinstance(size, list) and len(size) == 3 and all(is_number(s) for s in size)):
            rep.error(path, f + ".size", f"must be 3 numbers, got {size!r}")
            ok = False
        elif any(s <= 0 for s in size):
            rep.error(path, f + ".size", f"extents must be positive, got {size}")
            ok = False
        cap = o.get("capture")
        if not isinstance(cap, str):
            rep.error(path, f + ".capture", "missing or not a string")
            ok = False
        elif not os.path.isfile(os.path.join(room, cap, "transforms.json")):
            rep.error(path, f + ".capture", f"{cap!r} has no transforms.json")
            ok = False
        c2o = [[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0]]
        if "capture_to_object" in o:
            c2o = check_pose(rep, path, f + ".capture_to_object", o["capture_to_object"])
            ok = ok and c2o is not None
        rel = o.get("relations", [])
        if not (isinstance(rel, list) and all(isinstance(r, str) for r in rel)):
            rep.error(path, f + ".relations", "must be a list of strings")
            rel = []
        if ok:
            objects.append({"id": oid, "name": name, "size": [float(s) for s in size], "capture": cap,
                            "capture_to_object": c2o, "relations": rel})
    if not objects and not objs:
        rep.warn(path, "objects", "the room has no objects")
    for o in objects:
        for r in o["relations"]:
            if r.startswith("on:") and r[3:] not in names:
                rep.error(path, f"objects[{o['name']}].relations", f"{r!r} names no object of the room")
    return {"doc": doc, "objects": objects, "background": bg_capture, "all_ids": ids}


# --------------------------------------------------------------------------------------------------
# Pinhole captures

INTR = ("fl_x", "fl_y", "cx", "cy", "w", "h")
DIST = ("k1", "k2", "p1", "p2")


def frame_intrinsics(rep, path, field, top, fr):
    merged = {}
    for k in INTR + DIST + ("k3", "k4"):
        if k in fr:
            merged[k] = fr[k]
        elif k in top:
            merged[k] = top[k]
    ok = True
    for k in INTR:
        if k not in merged:
            rep.error(path, f"{field}.{k}", "missing (neither per frame nor top level)")
            ok = False
            continue
        v = merged[k]
        if k in ("w", "h"):
            if not (isinstance(v, int) and not isinstance(v, bool)) and not (is_number(v) and float(v).is_integer()):
                rep.error(path, f"{field}.{k}", f"must be an integer, got {v!r}")
                ok = False
            elif v <= 0:
                rep.error(path, f"{field}.{k}", f"must be positive, got {v}")
                ok = False
        elif not is_number(v):
            rep.error(path, f"{field}.{k}", f"must be a number, got {v!r}")
            ok = False
        elif k in ("fl_x", "fl_y") and v <= 0:
            rep.error(path, f"{field}.{k}", f"must be positive, got {v}")
            ok = False
    for k in DIST + ("k3", "k4"):
        if k in merged and not is_number(merged[k]):
            rep.error(path, f"{field}.{k}", f"must be a number, got {merged[k]!r}")
            ok = False
    if not ok:
        return None
    intr = {k: float(merged[k]) for k in INTR}
    intr["w"], intr["h"] = int(intr["w"]), int(intr["h"])
    intr["distorted"] = any(abs(float(merged.get(k, 0))) > 0 for k in DIST + ("k3", "k4"))
    return intr


class Capture:
    pass


def check_capture_json(rep, room, cap_rel, kind):
    """Checks transforms.json and the headers of every file it names. Returns a Capture or None."""
    cdir = os.path.join(room, cap_rel)
    path = os.path.join(cdir, "transforms.json")
    doc = load_json(rep, path)
    if doc is None:
        return None
    if not isinstance(doc, dict):
        rep.error(path, "(root)", "must be a JSON object")
        return None
    cm = doc.get("camera_model")
    if cm is None:
        rep.error(path, "camera_model", "missing")
    elif cm not in ("OPENCV", "PINHOLE", "SIMPLE_PINHOLE"):
        rep.error(path, "camera_model", f"must be a pinhole model (\"OPENCV\"), got {cm!r}")
    scale = doc.get("depth_unit_scale_factor", 0.001)
    if not is_number(scale) or scale <= 0:
        rep.error(path, "depth_unit_scale_factor", f"must be a positive number, got {scale!r}")
        scale = 0.001
    frames = doc.get("frames")
    if not isinstance(frames, list) or not frames:
        rep.error(path, "frames", "missing or empty")
        return None
    cap = Capture()
    cap.rel, cap.dir, cap.json_path, cap.kind, cap.scale = cap_rel, cdir, path, kind, float(scale)
    cap.frames = []
    for i, fr in enumerate(frames):
        field = f"frames[{i}]"
        if not isinstance(fr, dict):
            rep.error(path, field, "must be an object")
            continue
        intr = frame_intrinsics(rep, path, field, doc, fr)
        pose = check_pose(rep, path, field + ".transform_matrix", fr.get("transform_matrix"))
        rec = {"index": i, "intr": intr, "pose": pose, "image": None, "depth": None, "mask": None, "ok": True}
        for key, slot, required in (("file_path", "image", True), ("depth_file_path", "depth", False),
                                    ("instance_file_path", "mask", False)):
            fp = fr.get(key)
            if fp is None:
                if required:
                    rep.error(path, f"{field}.{key}", "missing")
                    rec["ok"] = False
                continue
            if not isinstance(fp, str):
                rep.error(path, f"{field}.{key}", "must be a string")
                rec["ok"] = False
                continue
            full = os.path.normpath(os.path.join(cdir, fp))
            if not os.path.isfile(full):
                rep.error(path, f"{field}.{key}", f"file {fp!r} does not exist")
                rec["ok"] = False
                continue
            try:
                hdr = image_header(full)
            except (ImageError, OSError, struct.error) as e:
                rep.error(full, key, f"unreadable image header: {e}")
                rec["ok"] = False
                continue
            kind_, w, h, bd, ct = hdr
            if intr is not None and (w, h) != (intr["w"], intr["h"]):
                rep.error(full, key, f"is {w}×{h}, transforms.json {field} says {intr['w']}×{intr['h']}")
                rec["ok"] = False
            if slot == "image":
                if kind_ == "png" and bd not in (8, 16) and ct != 3:
                    rep.error(full, key, f"bit depth {bd}: images must be 8-bit (16-bit PNG accepted)")
            elif slot == "depth":
                if kind_ != "png" or bd != 16 or ct != 0:
                    rep.error(full, key, f"depth must be a 16-bit grayscale PNG, got {kind_} bit depth {bd} colour type {ct}")
                    rec["ok"] = False
                    continue
            elif slot == "mask":
                if kind_ != "png" or bd not in (8, 16) or ct != 0:
                    rep.error(full, key, f"instance mask must be an 8- or 16-bit grayscale PNG, got {kind_} bit depth {bd} colour type {ct}")
                    rec["ok"] = False
                    continue
            rec[slot] = full
            rec[slot + "_hdr"] = hdr
        cap.frames.append(rec)
    return cap


def evenly(n, k):
    if k >= n:
        return list(range(n))
    return sorted({round(i * (n - 1) / (k - 1)) for i in range(k)}) if k > 1 else [0]


class FrameData:
    """Decoded depth (metres, list) and mask (list) of a frame."""

    def __init__(self, rep, cap, rec, need_image):
        self.ok = True
        self.depth = None
        self.mask = None
        self.alpha = None
        self.lum = None
        w, h = rec["intr"]["w"], rec["intr"]["h"]
        for slot in ("depth", "mask"):
            if rec[slot] is None:
                continue
            try:
                img = decode_png(rec[slot])
            except (ImageError, OSError, struct.error) as e:
                rep.error(rec[slot], slot, f"cannot decode: {e}")
                self.ok = False
                continue
            if (img.width, img.height) != (w, h):
                self.ok = False
                continue
            if slot == "depth":
                s = cap.scale
                self.depth = [v * s for v in img.samples]
            else:
                self.mask = img.samples
        if need_image and rec["image"] is not None and rec["image_hdr"][0] == "png":
            try:
                img = decode_png(rec["image"])
                if (img.width, img.height) == (w, h):
                    self.alpha = img.alpha()
                    self.lum = luminance(img)
            except (ImageError, OSError, struct.error) as e:
                rep.error(rec["image"], "file_path", f"cannot decode: {e}")
                self.ok = False


def luminance(img):
    c = img.channels - (1 if img.has_alpha else 0)
    if c >= 3:
        r, g, b = img.samples[0::img.channels], img.samples[1::img.channels], img.samples[2::img.channels]
        return [0.299 * x + 0.587 * y + 0.114 * z for x, y, z in zip(r, g, b)]
    return list(img.samples[0::img.channels])


def edge_alignment(lum, w, h, edge_fn, step=1):
    """Mean |horizontal luminance step| at pixels where edge_fn(i) says a depth/mask edge lies between
    pixel i and i+1, for the image as given, mirrored left-right and mirrored top-bottom."""
    sums = [0.0, 0.0, 0.0]
    n = 0
    for v in range(0, h, step):
        row = v * w
        mrow = (h - 1 - v) * w
        for u in range(0, w - 1):
            i = row + u
            if not edge_fn(i):
                continue
            n += 1
            sums[0] += abs(lum[i + 1] - lum[i])
            j = row + (w - 2 - u)
            sums[1] += abs(lum[j + 1] - lum[j])
            k = mrow + u
            sums[2] += abs(lum[k + 1] - lum[k])
    if n == 0:
        return None
    return [s / n for s in sums], n


def capture_pose_axes(pose):
    """Camera centre and viewing direction (−z of the OpenGL camera) in the capture frame."""
    c = (pose[0][3], pose[1][3], pose[2][3])
    d = (-pose[0][2], -pose[1][2], -pose[2][2])
    return c, d


def adaptive_stride(w, h, stride, target=4000):
    """The sampling step: at most `stride`, fine enough to keep about `target` samples in small images."""
    return max(1, min(stride, int(math.sqrt(w * h / target))))


def backproject_pinhole(intr, pose, depth, stride, select=None):
    """World points (capture frame) of every stride-th pixel with depth > 0 (and select(i) true)."""
    w, h = intr["w"], intr["h"]
    fx, fy, cx, cy = intr["fl_x"], intr["fl_y"], intr["cx"], intr["cy"]
    pts = []
    for v in range(stride // 2, h, stride):
        yv = (v + 0.5 - cy) / fy
        for u in range(stride // 2, w, stride):
            i = v * w + u
            z = depth[i]
            if z <= 0 or (select is not None and not select(i)):
                continue
            xu = (u + 0.5 - cx) / fx
            # OpenCV ray (x', y', 1) -> OpenGL camera (x', -y', -1), scaled by the z-depth.
            pc = (z * xu, -z * yv, -z)
            pts.append((transform(pose, pc), i))
    return pts


def sample_depth(depth, w, h, s, t):
    """Depth at continuous image coordinates (s, t) (pixel centres at +0.5): bilinear where the four
    neighbours agree, else the nearest pixel. None where there is no depth."""
    u, v = int(math.floor(s)), int(math.floor(t))
    if u < 0 or v < 0 or u >= w or v >= h:
        return None
    near = depth[v * w + u]
    a, b = s - 0.5, t - 0.5
    u0, v0 = int(math.floor(a)), int(math.floor(b))
    if 0 <= u0 and 0 <= v0 and u0 + 1 < w and v0 + 1 < h:
        d00 = depth[v0 * w + u0]
        d10 = depth[v0 * w + u0 + 1]
        d01 = depth[(v0 + 1) * w + u0]
        d11 = depth[(v0 + 1) * w + u0 + 1]
        lo = min(d00, d10, d01, d11)
        hi = max(d00, d10, d01, d11)
        if lo > 0 and hi - lo < 0.03 * hi:
            fa, fb = a - u0, b - v0
            return (d00 * (1 - fa) * (1 - fb) + d10 * fa * (1 - fb) + d01 * (1 - fa) * fb + d11 * fa * fb)
    return near if near > 0 else None


def project_pinhole(intr, world_to_cam, p):
    """(s, t, z) of a capture-frame point in a pinhole view, or None behind the camera."""
    q = transform(world_to_cam, p)
    z = -q[2]
    if z <= 1e-6:
        return None
    s = intr["fl_x"] * (q[0] / z) + intr["cx"]
    t = intr["fl_y"] * (-q[1] / z) + intr["cy"]
    return s, t, z


def check_capture_pixels(rep, room_info, cap, max_frames, stride, figures):
    """Decodes a sample of frames: ids, alpha vs mask/depth, depth reprojection, object boxes."""
    known = room_info["all_ids"]
    objs = [o for o in room_info["objects"] if o["capture"] is not None
            and os.path.normpath(o["capture"]) == os.path.normpath(cap.rel)]
    own_ids = {o["id"]: o for o in objs}
    usable = [r for r in cap.frames if r["ok"] and r["intr"] is not None and r["pose"] is not None]
    if not usable:
        rep.error(cap.json_path, "frames", "no usable frame to check")
        return
    sample = [usable[i] for i in evenly(len(usable), max_frames)]
    cache = {}

    def data(rec, need_image=False):
        key = rec["index"]
        if key not in cache or (need_image and cache[key].lum is None and rec["image_hdr"][0] == "png"):
            cache[key] = FrameData(rep, cap, rec, need_image)
        return cache[key]

    seen_ids = set()
    alpha_bad = alpha_total = 0
    edge_scores = []
    box_in = {oid: [0, 0] for oid in own_ids}
    obj_points = {oid: [] for oid in own_ids}
    extents = {oid: [[math.inf, -math.inf] for _ in range(3)] for oid in own_ids}
    errors_all = []
    pairs_done = 0
    for rec in sample:
        fd = data(rec, need_image=True)
        w, h = rec["intr"]["w"], rec["intr"]["h"]
        mask = fd.mask
        if mask is not None:
            ids_here = set(mask[::1]) - {0}
            unknown = ids_here - known
            if unknown:
                rep.error(rec["mask"], "instance value", f"ids {sorted(unknown)} are not objects of room.json")
            seen_ids |= ids_here
        # alpha 0 means "no surface": mask 0 and depth 0 there.
        if fd.alpha is not None and cap.kind == "object":
            bad = surf = 0
            dep = fd.depth
            for i, a in enumerate(fd.alpha):
                s_here = (mask is not None and mask[i] != 0) or (dep is not None and dep[i] > 0)
                if s_here:
                    surf += 1
                    if a == 0:
                        bad += 1
            alpha_bad += bad
            alpha_total += surf
        # RGB must line up with depth/mask (catches a mirrored or shifted image).
        if fd.lum is not None and (fd.depth is not None or mask is not None):
            dep = fd.depth
            if mask is not None and dep is not None:
                edge = lambda i: mask[i] != mask[i + 1] or (dep[i] > 0) != (dep[i + 1] > 0) or (
                    dep[i] > 0 and abs(dep[i] - dep[i + 1]) > 0.05 * dep[i])
            elif mask is not None:
                edge = lambda i: mask[i] != mask[i + 1]
            else:
                edge = lambda i: (dep[i] > 0) != (dep[i + 1] > 0) or (
                    dep[i] > 0 and abs(dep[i] - dep[i + 1]) > 0.05 * dep[i])
            r = edge_alignment(fd.lum, w, h, edge, step=2)
            if r is not None and r[1] >= 50:
                edge_scores.append((rec, r[0]))
        if fd.depth is None or rec["intr"]["distorted"]:
            continue
        st = adaptive_stride(w, h, stride)
        # Object pixels inside the object's box.
        if mask is not None:
            for oid, o in own_ids.items():
                c2o = o["capture_to_object"]
                half = [s / 2 + BOX_MARGIN_CAPTURE for s in o["size"]]
                pts = backproject_pinhole(rec["intr"], rec["pose"], fd.depth, st, lambda i: mask[i] == oid)
                ext = extents[oid]
                for p, _i in pts:
                    q = transform(c2o, p)
                    obj_points[oid].append(q)
                    box_in[oid][1] += 1
                    if abs(q[0]) <= half[0] and abs(q[1]) <= half[1] and abs(q[2]) <= half[2]:
                        box_in[oid][0] += 1
                    for k in range(3):
                        if q[k] < ext[k][0]:
                            ext[k][0] = q[k]
                        if q[k] > ext[k][1]:
                            ext[k][1] = q[k]
        # Depth reprojection into the partner view with the best overlap.
        partner = choose_partner(cap, rec, fd, usable)
        if partner is None:
            continue
        pd = data(partner)
        if pd.depth is None:
            continue
        errs = reprojection_errors(rec, fd, partner, pd, st)
        if len(errs) >= 50:
            pairs_done += 1
            errors_all.extend(errs)
    # Figures and verdicts.
    if cap.kind == "object" and objs and not (seen_ids & set(own_ids)):
        if any(r["mask"] for r in sample):
            rep.error(cap.json_path, "instance masks",
                      f"no sampled frame shows the id(s) {sorted(own_ids)} of the object(s) using this capture")
    if alpha_total:
        frac = alpha_bad / alpha_total
        figures.setdefault("alpha", []).append((cap.rel, frac, alpha_bad))
        rep.info(cap.json_path, f"pixels with a mask id or depth but alpha 0: {alpha_bad} = {100 * frac:.3f} % of "
                 f"{alpha_total} surface pixels")
        msg = (f"{alpha_bad} pixels ({100 * frac:.2f} % of the surface pixels of the sampled frames) have alpha 0 "
               "but a mask id or a depth: alpha 0 must mean no surface, exactly like mask 0")
        if frac > ALPHA_DISAGREE_MAX:
            rep.error(cap.json_path, "frames[].file_path alpha", msg)
        elif alpha_bad:
            rep.warn(cap.json_path, "frames[].file_path alpha", msg + " (silhouette pixels?)")
    if edge_scores:
        ratio = median([o / max(1e-9, max(hf, vf)) for _r, (o, hf, vf) in edge_scores])
        rep.info(cap.json_path, f"image edges vs depth/mask edges: as-is / best mirrored = {ratio:.2f} "
                 f"(median of {len(edge_scores)} frames; > 1 means aligned)")
    check_edge_scores(rep, cap.json_path, edge_scores)
    for oid, (inside, total) in box_in.items():
        o = own_ids[oid]
        if total == 0:
            continue
        frac = inside / total
        figures.setdefault("capture_box", []).append((o["name"], frac, total))
        ext = extents[oid]
        cover = [(ext[k][1] - ext[k][0]) / o["size"][k] for k in range(3)]
        rep.info(cap.json_path, f"object {o['name']!r} (id {oid}): {100 * frac:.2f} % of {total} object pixels "
                 f"inside its box (margin {100 * BOX_MARGIN_CAPTURE:.0f} cm); point extents / size = "
                 + ", ".join(f"{c:.3f}" for c in cover))
        if frac < BOX_INSIDE_MIN:
            rep.error(cap.json_path, f"objects[{o['name']}].size/capture_to_object",
                      f"only {100 * frac:.2f} % of back-projected object pixels lie inside the box "
                      f"(need ≥ {100 * BOX_INSIDE_MIN:.0f} %)")
        if total >= 500 and min(cover) < 0.6:
            rep.warn(cap.json_path, f"objects[{o['name']}].size",
                     "the object's pixels fill only " + ", ".join(f"{c:.2f}" for c in cover)
                     + " of the box extents: size may be too large")
    for oid, pts in obj_points.items():
        check_against_mesh(rep, room_info, own_ids[oid], pts, cap.json_path,
                           f"objects[{own_ids[oid]['name']}].capture_to_object / frames[].transform_matrix",
                           "capture", figures)
    if errors_all:
        med = median(errors_all)
        within = sum(1 for e in errors_all if e < 0.01) / len(errors_all)
        figures.setdefault("reproj", []).append((cap.rel, med, len(errors_all)))
        rep.info(cap.json_path, f"depth reprojection: median |error| {1000 * med:.2f} mm over {len(errors_all)} "
                 f"pixels in {pairs_done} view pairs; {100 * within:.1f} % within 1 cm")
        if med > REPROJ_MEDIAN_MAX:
            rep.error(cap.json_path, "frames[].transform_matrix/intrinsics/depth",
                      f"depth does not reproject between views: median error {100 * med:.1f} cm "
                      f"(need ≤ {100 * REPROJ_MEDIAN_MAX:.0f} cm) — pose, intrinsics or depth convention is wrong")
        elif med > REPROJ_MEDIAN_WARN:
            rep.warn(cap.json_path, "frames[].transform_matrix/intrinsics/depth",
                     f"depth reprojects with a median error of {1000 * med:.1f} mm: a small intrinsics or pose offset?")
    elif any(r["depth"] for r in sample):
        if any(r["intr"]["distorted"] for r in sample):
            rep.warn(cap.json_path, "k1/k2/p1/p2", "distorted camera: geometry checks skipped")
        else:
            rep.warn(cap.json_path, "frames", "no pair of views overlaps enough to test depth reprojection")


def check_against_mesh(rep, room_info, obj, points, path, field, what, figures):
    """Object-frame points of an object's pixels must lie on its ground-truth mesh."""
    if not points:
        return
    index = mesh_index(room_info["room"], obj["name"])
    if index is None:
        return
    d = mesh_distances(index, points)
    med = median(d)
    within = sum(1 for x in d if x < MESH_CUTOFF) / len(d)
    figures.setdefault("mesh_dist", []).append((what, obj["name"], med, within))
    rep.info(path, f"object {obj['name']!r}: {what} pixels vs meshes/{obj['name']}.ply: median distance "
             f"{1000 * med:.2f} mm, {100 * within:.1f} % within {100 * MESH_CUTOFF:.0f} cm ({len(d)} points)")
    if med > MESH_MEDIAN_MAX:
        rep.error(path, field, f"{obj['name']!r} pixels lie off its ground-truth mesh: median distance "
                  f"{'≥ ' if med >= MESH_CUTOFF else ''}{1000 * med:.1f} mm (need ≤ {1000 * MESH_MEDIAN_MAX:.0f} mm)")
    elif med > MESH_MEDIAN_WARN:
        rep.warn(path, field, f"{obj['name']!r} pixels lie {1000 * med:.1f} mm (median) from its ground-truth mesh: "
                 "a small pose or intrinsics offset?")


def check_edge_scores(rep, path, scores):
    """Flags an image that lines up better with its depth/mask when mirrored."""
    for rec, (orig, hflip, vflip) in scores:
        best_other = max(hflip, vflip)
        if orig < 0.8 * best_other and best_other > 2.0:
            which = "left-right" if hflip >= vflip else "top-bottom"
            rep.error(rec["image"], "file_path",
                      f"image edges match the depth/mask edges better when mirrored {which} "
                      f"({orig:.1f} vs {best_other:.1f}): image and depth/mask disagree")


def choose_partner(cap, rec, fd, usable):
    """The other frame that sees most of this frame's points, not a near duplicate."""
    pts = backproject_pinhole(rec["intr"], rec["pose"], fd.depth, adaptive_stride(rec["intr"]["w"], rec["intr"]["h"], 16, 300))
    if len(pts) < 10:
        return None
    c0, d0 = capture_pose_axes(rec["pose"])
    best, best_score = None, -1.0
    fallback, fallback_score = None, -1.0
    for other in usable:
        if other is rec or other["depth"] is None or other["intr"]["distorted"]:
            continue
        c1, d1 = capture_pose_axes(other["pose"])
        cosang = max(-1.0, min(1.0, sum(a * b for a, b in zip(d0, d1))))
        ang = math.degrees(math.acos(cosang))
        base = math.dist(c0, c1)
        w2c = mat_inv_rigid(other["pose"])
        w, h = other["intr"]["w"], other["intr"]["h"]
        inside = 0
        for p, _i in pts:
            r = project_pinhole(other["intr"], w2c, p)
            if r is not None and 0 <= r[0] < w and 0 <= r[1] < h:
                inside += 1
        score = inside / len(pts)
        # Prefer the nearest viewing direction that is not a near duplicate and still sees most points:
        # wide baselines bring self-occlusion, which is not what this check measures.
        if (ang >= 8.0 or base >= 0.3) and score >= 0.5:
            key = ang + 20.0 * (1.0 - score)
            if best is None or key < best_score:
                best, best_score = other, key
        elif score > fallback_score:
            fallback, fallback_score = other, score
    if best is not None:
        return best
    return fallback if fallback is not None and fallback_score >= 0.3 else None


def backproject_with_normals(intr, pose, depth, stride):
    """Like backproject_pinhole, with a surface normal from the neighbouring pixels (right and below);
    pixels at a depth discontinuity (> 3 %) or beside a pixel without depth are left out."""
    w, h = intr["w"], intr["h"]
    fx, fy, cx, cy = intr["fl_x"], intr["fl_y"], intr["cx"], intr["cy"]

    def point(u, v, z):
        return transform(pose, (z * (u + 0.5 - cx) / fx, -z * (v + 0.5 - cy) / fy, -z))

    out = []
    for v in range(stride // 2, h - 1, stride):
        for u in range(stride // 2, w - 1, stride):
            i = v * w + u
            z, zr, zd = depth[i], depth[i + 1], depth[i + w]
            if z <= 0 or zr <= 0 or zd <= 0 or abs(zr - z) > 0.03 * z or abs(zd - z) > 0.03 * z:
                continue
            p = point(u, v, z)
            a = point(u + 1, v, zr)
            b = point(u, v + 1, zd)
            ax, ay, az = a[0] - p[0], a[1] - p[1], a[2] - p[2]
            bx, by, bz = b[0] - p[0], b[1] - p[1], b[2] - p[2]
            n = (ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx)
            ln = math.sqrt(n[0] ** 2 + n[1] ** 2 + n[2] ** 2)
            if ln == 0:
                continue
            out.append((p, (n[0] / ln, n[1] / ln, n[2] / ln)))
    return out


def reprojection_errors(rec, fd, other, od, stride):
    """|observed − expected| z-depth of this frame's points seen from `other`, for points whose surface
    faces both cameras (incidence < 70°), so that back faces and grazing views do not count."""
    intr = other["intr"]
    w, h = intr["w"], intr["h"]
    w2c = mat_inv_rigid(other["pose"])
    c0, _ = capture_pose_axes(rec["pose"])
    c1, _ = capture_pose_axes(other["pose"])
    cos_min = math.cos(math.radians(70.0))
    errs = []
    for p, n in backproject_with_normals(rec["intr"], rec["pose"], fd.depth, stride):
        faces = []
        for c in (c0, c1):
            d = (c[0] - p[0], c[1] - p[1], c[2] - p[2])
            ld = math.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
            faces.append((n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / ld if ld > 0 else 0.0)
        # The normal is oriented towards the source camera; the target must see the same side.
        if abs(faces[0]) < cos_min or faces[0] * faces[1] <= 0 or abs(faces[1]) < cos_min:
            continue
        r = project_pinhole(intr, w2c, p)
        if r is None:
            continue
        s, t, z = r
        obs = sample_depth(od.depth, w, h, s, t)
        if obs is None:
            continue
        errs.append(abs(obs - z))
    return errs


# --------------------------------------------------------------------------------------------------
# Meshes

PLY_TYPES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h",
             "ushort": "H", "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I",
             "float": "f", "float32": "f", "double": "d", "float64": "d"}


def ply_read(path):
    """(vertices [(x, y, z)], faces [(i, j, k)] fan-triangulated) of a PLY: ascii, binary little or big endian."""
    with open(path, "rb") as f:
        data = f.read()
    if not data.startswith(b"ply"):
        raise ValueError("not a PLY file (no 'ply' magic)")
    end = data.find(b"end_header")
    if end < 0:
        raise ValueError("no end_header")
    nl = data.find(b"\n", end)
    header = data[:end].decode("ascii", "replace").splitlines()
    body_pos = nl + 1
    fmt = None
    elements = []
    for line in header[1:]:
        parts = line.split()
        if not parts or parts[0] in ("comment", "obj_info"):
            continue
        if parts[0] == "format":
            fmt = parts[1]
        elif parts[0] == "element":
            elements.append({"name": parts[1], "count": int(parts[2]), "props": []})
        elif parts[0] == "property":
            if not elements:
                raise ValueError("property before element")
            if parts[1] == "list":
                elements[-1]["props"].append(("list", parts[2], parts[3], parts[4]))
            else:
                elements[-1]["props"].append(("scalar", parts[1], parts[2]))
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise ValueError(f"unsupported format {fmt!r}")
    verts, faces = [], []

    def add_face(idx):
        for k in range(1, len(idx) - 1):
            faces.append((idx[0], idx[k], idx[k + 1]))

    if fmt == "ascii":
        tokens = data[body_pos:].split()
        tp = 0
        for el in elements:
            for _ in range(el["count"]):
                vals = {}
                for prop in el["props"]:
                    if prop[0] == "list":
                        n = int(tokens[tp])
                        vals[prop[3]] = [int(x) for x in tokens[tp + 1: tp + 1 + n]]
                        tp += 1 + n
                    else:
                        vals[prop[2]] = float(tokens[tp])
                        tp += 1
                if el["name"] == "vertex":
                    verts.append((vals["x"], vals["y"], vals["z"]))
                elif el["name"] == "face":
                    idx = vals.get("vertex_indices", vals.get("vertex_index"))
                    if idx is not None:
                        add_face(idx)
    else:
        endian = "<" if fmt == "binary_little_endian" else ">"
        pos = body_pos
        for el in elements:
            props = el["props"]
            if all(p[0] == "scalar" for p in props):
                st = struct.Struct(endian + "".join(PLY_TYPES[p[1]] for p in props))
                chunk = data[pos: pos + st.size * el["count"]]
                if len(chunk) < st.size * el["count"]:
                    raise ValueError("file shorter than its header says")
                if el["name"] == "vertex":
                    names = [p[2] for p in props]
                    ix, iy, iz = names.index("x"), names.index("y"), names.index("z")
                    verts = [(r[ix], r[iy], r[iz]) for r in st.iter_unpack(chunk)]
                pos += st.size * el["count"]
                continue
            if el["name"] == "vertex":
                raise ValueError("vertex element with list properties")
            is_face = el["name"] == "face"
            for _ in range(el["count"]):
                for p in props:
                    if p[0] == "list":
                        cst = struct.Struct(endian + PLY_TYPES[p[1]])
                        (n,) = cst.unpack_from(data, pos)
                        pos += cst.size
                        ist = struct.Struct(endian + PLY_TYPES[p[2]] * n)
                        if is_face and p[3] in ("vertex_indices", "vertex_index"):
                            add_face(ist.unpack_from(data, pos))
                        pos += ist.size
                    else:
                        pos += struct.calcsize(endian + PLY_TYPES[p[1]])
            if pos > len(data):
                raise ValueError("file shorter than its header says")
    if not verts:
        raise ValueError("no vertices")
    nv = len(verts)
    for f in faces:
        if min(f) < 0 or max(f) >= nv:
            raise ValueError(f"face index out of range (vertices: {nv})")
    return verts, faces


def ply_bbox(path):
    """(min xyz, max xyz, vertex count, face count) of a PLY."""
    verts, faces = ply_read(path)
    lo = [min(v[k] for v in verts) for k in range(3)]
    hi = [max(v[k] for v in verts) for k in range(3)]
    return lo, hi, len(verts), len(faces)


def closest_on_triangle(p, a, b, c):
    """Squared distance from p to triangle abc (Ericson, Real-Time Collision Detection 5.1.5)."""
    ab = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
    ac = (c[0] - a[0], c[1] - a[1], c[2] - a[2])
    ap = (p[0] - a[0], p[1] - a[1], p[2] - a[2])
    d1 = ab[0] * ap[0] + ab[1] * ap[1] + ab[2] * ap[2]
    d2 = ac[0] * ap[0] + ac[1] * ap[1] + ac[2] * ap[2]
    if d1 <= 0 and d2 <= 0:
        q = a
    else:
        bp = (p[0] - b[0], p[1] - b[1], p[2] - b[2])
        d3 = ab[0] * bp[0] + ab[1] * bp[1] + ab[2] * bp[2]
        d4 = ac[0] * bp[0] + ac[1] * bp[1] + ac[2] * bp[2]
        cp = (p[0] - c[0], p[1] - c[1], p[2] - c[2])
        d5 = ab[0] * cp[0] + ab[1] * cp[1] + ab[2] * cp[2]
        d6 = ac[0] * cp[0] + ac[1] * cp[1] + ac[2] * cp[2]
        vc = d1 * d4 - d3 * d2
        vb = d5 * d2 - d1 * d6
        va = d3 * d6 - d5 * d4
        if d3 >= 0 and d4 <= d3:
            q = b
        elif vc <= 0 and d1 >= 0 and d3 <= 0:
            t = d1 / (d1 - d3)
            q = (a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2])
        elif d6 >= 0 and d5 <= d6:
            q = c
        elif vb <= 0 and d2 >= 0 and d6 <= 0:
            t = d2 / (d2 - d6)
            q = (a[0] + t * ac[0], a[1] + t * ac[1], a[2] + t * ac[2])
        elif va <= 0 and (d4 - d3) >= 0 and (d5 - d6) >= 0:
            t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            q = (b[0] + t * (c[0] - b[0]), b[1] + t * (c[1] - b[1]), b[2] + t * (c[2] - b[2]))
        else:
            den = 1.0 / (va + vb + vc)
            v = vb * den
            w = vc * den
            q = (a[0] + ab[0] * v + ac[0] * w, a[1] + ab[1] * v + ac[1] * w, a[2] + ab[2] * v + ac[2] * w)
    return (p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2 + (p[2] - q[2]) ** 2


class MeshIndex:
    """Point-to-mesh distance up to `cutoff`: triangles hashed into cells of that size (dilated by it)."""

    def __init__(self, verts, faces, cutoff=0.02):
        self.cell = cutoff
        self.grid = {}
        cell = cutoff
        for f in faces:
            a, b, c = verts[f[0]], verts[f[1]], verts[f[2]]
            lo = [int(math.floor((min(a[k], b[k], c[k]) - cell) / cell)) for k in range(3)]
            hi = [int(math.floor((max(a[k], b[k], c[k]) + cell) / cell)) for k in range(3)]
            if (hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1) > 200000:
                continue  # absurdly large triangle: leave it out rather than stall
            tri = (a, b, c)
            for ix in range(lo[0], hi[0] + 1):
                for iy in range(lo[1], hi[1] + 1):
                    for iz in range(lo[2], hi[2] + 1):
                        self.grid.setdefault((ix, iy, iz), []).append(tri)
        # Cells crowded with tiny triangles keep their vertices only: there, the nearest vertex is as good.
        self.points = {}
        for key in [k for k, v in self.grid.items() if len(v) > 400]:
            self.points[key] = list({v for tri in self.grid.pop(key) for v in tri})

    def distance(self, p):
        key = (int(math.floor(p[0] / self.cell)), int(math.floor(p[1] / self.cell)), int(math.floor(p[2] / self.cell)))
        best = self.cell * self.cell
        pts = self.points.get(key)
        if pts is not None:
            x, y, z = p
            for q in pts:
                d = (x - q[0]) ** 2 + (y - q[1]) ** 2 + (z - q[2]) ** 2
                if d < best:
                    best = d
            return math.sqrt(best)
        tris = self.grid.get(key)
        if not tris:
            return self.cell
        for a, b, c in tris:
            d = closest_on_triangle(p, a, b, c)
            if d < best:
                best = d
        return math.sqrt(best)


_MESH_CACHE = {}


def mesh_index(room, name):
    """The MeshIndex of meshes/<name>.ply, or None when there is none (or it does not parse)."""
    if name in _MESH_CACHE:
        return _MESH_CACHE[name]
    path = os.path.join(room, "meshes", name + ".ply")
    idx = None
    if os.path.isfile(path):
        try:
            verts, faces = ply_read(path)
            if faces:
                idx = MeshIndex(verts, faces, MESH_CUTOFF)
        except (ValueError, KeyError, IndexError, struct.error, OSError):
            idx = None  # reported by check_meshes
    _MESH_CACHE[name] = idx
    return idx


def mesh_distances(index, points, limit=600):
    """Distances (capped at the cutoff) of an evenly thinned subset of object-frame points."""
    if len(points) > limit:
        step = len(points) / limit
        points = [points[int(i * step)] for i in range(limit)]
    return [index.distance(p) for p in points]


def check_meshes(rep, room, room_info, figures):
    mdir = os.path.join(room, "meshes")
    if not os.path.isdir(mdir):
        return
    by_name = {o["name"]: o for o in room_info["objects"]}
    for fn in sorted(os.listdir(mdir)):
        if not fn.endswith(".ply"):
            continue
        path = os.path.join(mdir, fn)
        name = fn[:-4]
        o = by_name.get(name)
        if o is None:
            rep.warn(path, "file name", f"no object named {name!r} in room.json")
            continue
        try:
            lo, hi, nv, nf = ply_bbox(path)
        except (ValueError, KeyError, IndexError, struct.error, OSError) as e:
            rep.error(path, "file", f"cannot parse PLY: {e}")
            continue
        ext = [hi[k] - lo[k] for k in range(3)]
        ctr = [(hi[k] + lo[k]) / 2 for k in range(3)]
        rel = [ext[k] / o["size"][k] - 1 for k in range(3)]
        figures.setdefault("mesh", []).append((name, max(abs(r) for r in rel), max(abs(c) for c in ctr)))
        rep.info(path, f"bbox extents {', '.join(f'{e:.4f}' for e in ext)} m vs size "
                 f"{', '.join(f'{s:.4f}' for s in o['size'])} (max rel. error {100 * max(abs(r) for r in rel):.2f} %), "
                 f"centre {', '.join(f'{c:+.4f}' for c in ctr)}; {nv} vertices, {nf} faces")
        if max(abs(r) for r in rel) > MESH_SIZE_TOL:
            rep.error(path, "vertex bbox", f"extents {[round(e, 4) for e in ext]} differ from room.json size "
                      f"{o['size']} by up to {100 * max(abs(r) for r in rel):.1f} % (> {100 * MESH_SIZE_TOL:.0f} %)")
        for k in range(3):
            if abs(ctr[k]) > 0.01 * o["size"][k] + 0.002:
                rep.error(path, "vertex bbox", f"not centred at the origin: centre {'xyz'[k]} = {ctr[k]:+.4f} m")
                break


# --------------------------------------------------------------------------------------------------
# Panoramas

def check_panoramas(rep, room, room_info, stride, figures):
    pdir = os.path.join(room, "panoramas")
    if not os.path.isdir(pdir):
        rep.warn(pdir, "directory", "no panoramas/ folder")
        return
    files = sorted(os.listdir(pdir))
    bases = [f for f in files if f.lower().endswith((".png", ".jpg", ".jpeg"))
             and not f.endswith((".depth.png", ".mask.png"))]
    by_id = {o["id"]: o for o in room_info["objects"]}
    by_name = {o["name"]: o for o in room_info["objects"]}
    for f in files:
        if f.endswith((".depth.png", ".mask.png")) or (f.endswith(".json")):
            stem = f[: -len(".depth.png")] if f.endswith(".depth.png") else (
                f[: -len(".mask.png")] if f.endswith(".mask.png") else f[:-5])
            if not any(os.path.splitext(b)[0] == stem for b in bases):
                rep.error(os.path.join(pdir, f), "file name", f"no panorama image {stem}.png beside it")
    for b in bases:
        stem = os.path.splitext(b)[0]
        pst = None
        ipath = os.path.join(pdir, b)
        try:
            kind, W, H, bd, ct = image_header(ipath)
        except (ImageError, OSError, struct.error) as e:
            rep.error(ipath, "file", f"unreadable image: {e}")
            continue
        if W != 2 * H:
            rep.error(ipath, "size", f"{W}×{H} is not 2:1 (width must be 2 × height)")
        pano_img = None
        if kind == "png":
            try:
                pano_img = decode_png(ipath)
            except (ImageError, OSError, struct.error) as e:
                rep.error(ipath, "file", f"cannot decode: {e}")
        jpath = os.path.join(pdir, stem + ".json")
        arr = None
        if os.path.exists(jpath):
            arr = check_arrangement(rep, jpath, b, room_info)
        depth = mask = None
        scale = 0.001
        if arr is not None and is_number(arr["doc"].get("depth_unit_scale_factor")):
            scale = float(arr["doc"]["depth_unit_scale_factor"])
        for suffix, slot in ((".depth.png", "depth"), (".mask.png", "mask")):
            p = os.path.join(pdir, stem + suffix)
            if not os.path.exists(p):
                continue
            try:
                img = decode_png(p)
            except (ImageError, OSError, struct.error) as e:
                rep.error(p, "file", f"cannot decode: {e}")
                continue
            if (img.width, img.height) != (W, H):
                rep.error(p, "size", f"is {img.width}×{img.height}, the panorama is {W}×{H}")
                continue
            if slot == "depth":
                if img.color_type != 0 or img.bit_depth != 16:
                    rep.error(p, "format", "panorama depth must be a 16-bit grayscale PNG")
                    continue
                depth = [v * scale for v in img.samples]
            else:
                if img.color_type != 0:
                    rep.error(p, "format", "instance mask must be an 8- or 16-bit grayscale PNG")
                    continue
                mask = img.samples
                unknown = set(mask) - {0} - room_info["all_ids"]
                if unknown:
                    rep.error(p, "instance value", f"ids {sorted(unknown)} are not objects of room.json")
                if arr is not None:
                    missing = set(mask) - {0} - set(arr["poses"]) - unknown
                    if missing:
                        rep.error(p, "instance value", f"ids {sorted(missing)} are not placed in {stem}.json")
        if pano_img is not None and (depth is not None or mask is not None) and W == 2 * H:
            lum = luminance(pano_img)
            if mask is not None and depth is not None:
                edge = lambda i: mask[i] != mask[i + 1] or (depth[i] > 0 and abs(depth[i] - depth[i + 1]) > 0.05 * depth[i])
            elif mask is not None:
                edge = lambda i: mask[i] != mask[i + 1]
            else:
                edge = lambda i: depth[i] > 0 and abs(depth[i] - depth[i + 1]) > 0.05 * depth[i]
            r = edge_alignment(lum, W, H, edge, step=2)
            if r is not None and r[1] >= 50:
                rep.info(ipath, "edge alignment image vs depth/mask: as is {:.1f}, mirrored L-R {:.1f}, T-B {:.1f}".format(*r[0]))
                check_edge_scores(rep, ipath, [({"image": ipath}, r[0])])
        if arr is None or W != 2 * H:
            continue
        pst = adaptive_stride(W, H, max(1, stride // 2), 30000)
        check_arrangement_geometry(rep, pdir, stem, arr, room_info, by_id, by_name, depth, mask, W, H, pst, figures)


def check_arrangement(rep, path, image_name, room_info):
    doc = load_json(rep, path)
    if doc is None:
        return None
    if not isinstance(doc, dict):
        rep.error(path, "(root)", "must be a JSON object")
        return None
    if doc.get("format") != "neuroom.arrangement/1":
        rep.error(path, "format", f"must be \"neuroom.arrangement/1\", got {doc.get('format')!r}")
    if "image" in doc and doc["image"] != image_name and os.path.basename(str(doc["image"])) != image_name:
        rep.warn(path, "image", f"names {doc['image']!r}, the file beside it is {image_name!r}")
    c2w = check_pose(rep, path, "camera_to_world", doc.get("camera_to_world"))
    objs = doc.get("objects")
    poses = {}
    if not isinstance(objs, list):
        rep.error(path, "objects", "missing or not a list")
        objs = []
    by_id = {o["id"]: o for o in room_info["objects"]}
    for i, o in enumerate(objs):
        f = f"objects[{i}]"
        if not isinstance(o, dict):
            rep.error(path, f, "must be an object")
            continue
        oid = o.get("id")
        if oid not in room_info["all_ids"]:
            rep.error(path, f + ".id", f"{oid!r} is not an object id of room.json")
            continue
        if oid in poses:
            rep.error(path, f + ".id", f"id {oid} placed twice")
            continue
        if "name" in o and oid in by_id and o["name"] != by_id[oid]["name"]:
            rep.error(path, f + ".name", f"{o['name']!r} but room.json calls id {oid} {by_id[oid]['name']!r}")
        m = check_pose(rep, path, f + ".object_to_world", o.get("object_to_world"))
        if m is not None and oid in by_id:
            poses[oid] = m
    return {"doc": doc, "c2w": c2w, "poses": poses, "path": path}


def check_arrangement_geometry(rep, pdir, stem, arr, room_info, by_id, by_name, depth, mask, W, H, stride, figures):
    path = arr["path"]
    poses = arr["poses"]
    # Support relations.
    for oid, m in poses.items():
        o = by_id[oid]
        bottom = min(c[2] for c in box_corners(o["size"], m))
        for rel in o["relations"]:
            if rel == "floor":
                if abs(bottom) > FLOOR_TOL:
                    rep.error(path, f"objects[{o['name']}].object_to_world",
                              f"relation \"floor\" but the box bottom is at z = {bottom:+.3f} m")
            elif rel.startswith("on:") and rel[3:] in by_name and by_name[rel[3:]]["id"] in poses:
                sup = by_name[rel[3:]]
                top = max(c[2] for c in box_corners(sup["size"], poses[sup["id"]]))
                if abs(bottom - top) > ON_TOL:
                    rep.error(path, f"objects[{o['name']}].object_to_world",
                              f"relation {rel!r} but its bottom z = {bottom:.3f} m is not the top of "
                              f"{sup['name']!r} (z = {top:.3f} m)")
    # Interpenetration.
    ids = sorted(poses)
    worst = (0.0, None)
    for a in range(len(ids)):
        for b in range(a + 1, len(ids)):
            oa, ob = by_id[ids[a]], by_id[ids[b]]
            va = oa["size"][0] * oa["size"][1] * oa["size"][2]
            vb = ob["size"][0] * ob["size"][1] * ob["size"][2]
            if va <= vb:
                frac = box_overlap_fraction(oa["size"], poses[ids[a]], ob["size"], poses[ids[b]])
            else:
                frac = box_overlap_fraction(ob["size"], poses[ids[b]], oa["size"], poses[ids[a]])
            if frac > worst[0]:
                worst = (frac, (oa["name"], ob["name"]))
    figures.setdefault("overlap", []).append(worst[0])
    if len(ids) > 1:
        rep.info(path, f"max box overlap {100 * worst[0]:.1f} % of the smaller box"
                 + (f" ({worst[1][0]} / {worst[1][1]})" if worst[1] else ""))
    if worst[0] > OVERLAP_MAX:
        rep.error(path, "objects[].object_to_world",
                  f"boxes of {worst[1][0]!r} and {worst[1][1]!r} interpenetrate: {100 * worst[0]:.0f} % of the smaller box")
    if depth is None or mask is None or arr["c2w"] is None:
        return
    c2w = arr["c2w"]
    w2o = {oid: mat_mul(mat_inv_rigid(m), c2w) for oid, m in poses.items()}  # camera -> object
    half_out = {oid: [s / 2 + BOX_MARGIN_PANO for s in by_id[oid]["size"]] for oid in poses}
    half_in = {oid: [s / 2 - BOX_MARGIN_PANO for s in by_id[oid]["size"]] for oid in poses}
    counts = {oid: [0, 0] for oid in poses}
    obj_points = {oid: [] for oid in poses}
    bg_in = bg_total = 0
    for v in range(stride // 2, H, stride):
        lat = math.pi * (0.5 - (v + 0.5) / H)
        cl, sl = math.cos(lat), math.sin(lat)
        for u in range(stride // 2, W, stride):
            i = v * W + u
            d = depth[i]
            if d <= 0:
                continue
            lon = math.pi * (1 - 2 * (u + 0.5) / W)
            p = (d * cl * math.cos(lon), d * cl * math.sin(lon), d * sl)
            k = mask[i]
            if k:
                if k not in w2o:
                    continue
                q = transform(w2o[k], p)
                obj_points[k].append(q)
                hb = half_out[k]
                counts[k][1] += 1
                if abs(q[0]) <= hb[0] and abs(q[1]) <= hb[1] and abs(q[2]) <= hb[2]:
                    counts[k][0] += 1
            else:
                bg_total += 1
                for oid, m in w2o.items():
                    hb = half_in[oid]
                    if min(hb) <= 0:
                        continue
                    q = transform(m, p)
                    if abs(q[0]) <= hb[0] and abs(q[1]) <= hb[1] and abs(q[2]) <= hb[2]:
                        bg_in += 1
                        break
    parts = []
    for oid, (inside, total) in sorted(counts.items()):
        if total == 0:
            continue
        frac = inside / total
        figures.setdefault("pano_box", []).append((stem, by_id[oid]["name"], frac, total))
        parts.append(f"{by_id[oid]['name']} {100 * frac:.2f} % of {total}")
        if frac < BOX_INSIDE_MIN:
            rep.error(path, f"objects[{by_id[oid]['name']}].object_to_world",
                      f"only {100 * frac:.1f} % of the panorama's pixels with id {oid} lie inside the object's box "
                      f"(margin {100 * BOX_MARGIN_PANO:.0f} cm; need ≥ {100 * BOX_INSIDE_MIN:.0f} %)")
    for oid, pts in obj_points.items():
        check_against_mesh(rep, room_info, by_id[oid], pts, path,
                           f"objects[{by_id[oid]['name']}].object_to_world", "panorama", figures)
    bg_frac = bg_in / bg_total if bg_total else 0.0
    figures.setdefault("pano_bg", []).append(bg_frac)
    rep.info(path, "mask pixels inside their box: " + (", ".join(parts) if parts else "(no object pixels)")
             + f"; id-0 pixels inside some box: {100 * bg_frac:.2f} % of {bg_total}")
    if bg_frac > PANO_BG_INSIDE_MAX:
        rep.error(stem + ".mask.png", "instance value 0",
                  f"{100 * bg_frac:.1f} % of pixels without an id lie inside an object's box")


# --------------------------------------------------------------------------------------------------

def validate(room, max_frames=6, stride=4, quiet=False):
    rep = Report(room, quiet)
    figures = {}
    info = check_room_json(rep, room)
    if info is None:
        return rep, figures
    info["room"] = room
    caps = []
    seen = set()
    if info["background"] is not None and os.path.isfile(os.path.join(room, info["background"], "transforms.json")):
        caps.append((info["background"], "background"))
        seen.add(os.path.normpath(info["background"]))
    for o in info["objects"]:
        key = os.path.normpath(o["capture"])
        if key not in seen:
            seen.add(key)
            caps.append((o["capture"], "object"))
    for rel, kind in caps:
        cap = check_capture_json(rep, room, rel, kind)
        if cap is None:
            continue
        try:
            check_capture_pixels(rep, info, cap, max_frames, stride, figures)
        except (ImageError, ValueError, IndexError, KeyError, TypeError, struct.error) as e:
            rep.error(cap.json_path, "frames", f"check aborted: {type(e).__name__}: {e}")
    try:
        check_meshes(rep, room, info, figures)
    except (ValueError, KeyError, TypeError) as e:
        rep.error(os.path.join(room, "meshes"), "files", f"check aborted: {e}")
    try:
        check_panoramas(rep, room, info, stride, figures)
    except (ImageError, ValueError, IndexError, KeyError, TypeError, struct.error) as e:
        rep.error(os.path.join(room, "panoramas"), "files", f"check aborted: {type(e).__name__}: {e}")
    return rep, figures


def main(argv):
    import argparse
    import time

    ap = argparse.ArgumentParser(description="Validate a neuroom room against docs/formats.md (stdlib only).")
    ap.add_argument("room", help="room folder (holding room.json)")
    ap.add_argument("--max-frames", type=int, default=6, help="frames decoded per capture (default 6)")
    ap.add_argument("--stride", type=int, default=4, help="pixel sampling step in captures (default 4)")
    ap.add_argument("--quiet", action="store_true", help="do not print INFO lines")
    try:
        args = ap.parse_args(argv)
    except SystemExit as e:
        return 2 if e.code else 0
    if args.max_frames < 1 or args.stride < 1:
        print("validate_room: --max-frames and --stride must be ≥ 1", file=sys.stderr)
        return 2
    if not os.path.isdir(args.room):
        print(f"validate_room: {args.room!r} is not a folder", file=sys.stderr)
        return 2
    t0 = time.time()
    rep, figures = validate(args.room, args.max_frames, args.stride, args.quiet)
    summary = []
    if figures.get("reproj"):
        summary.append("depth reprojection median " + ", ".join(
            f"{os.path.basename(c)} {1000 * m:.2f} mm" for c, m, _n in figures["reproj"]))
    if figures.get("capture_box"):
        summary.append("capture pixels in box " + ", ".join(f"{n} {100 * f:.2f} %" for n, f, _t in figures["capture_box"]))
    if figures.get("pano_box"):
        fr = [f for _s, _n, f, _t in figures["pano_box"]]
        summary.append(f"panorama pixels in box min {100 * min(fr):.2f} %")
    if figures.get("pano_bg"):
        summary.append(f"id-0 panorama pixels in a box max {100 * max(figures['pano_bg']):.2f} %")
    if figures.get("overlap"):
        summary.append(f"max box overlap {100 * max(figures['overlap']):.1f} %")
    if figures.get("alpha"):
        summary.append("surface pixels with alpha 0: " + ", ".join(
            f"{os.path.basename(c)} {n} ({100 * f:.2f} %)" for c, f, n in figures["alpha"]))
    if figures.get("mesh_dist"):
        for what in ("capture", "panorama"):
            ms = [m for w, _n, m, _f in figures["mesh_dist"] if w == what]
            if ms:
                summary.append(f"{what} object pixels to GT mesh: worst median {1000 * max(ms):.2f} mm")
    if figures.get("mesh"):
        summary.append(f"mesh bbox vs size max {100 * max(r for _n, r, _c in figures['mesh']):.2f} %")
    for s in summary:
        print("FIGURE " + s)
    verdict = "VALID" if not rep.problems else "INVALID"
    print(f"{verdict}: {args.room}: {len(rep.problems)} problem(s), {len(rep.warnings)} warning(s) "
          f"in {time.time() - t0:.1f} s")
    return 0 if not rep.problems else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
