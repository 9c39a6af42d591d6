#!/bin/sh
# Fills fuzz/corpus/<target>/ with seed inputs from neuroom-core's test corpus and its tiny room.
# Run from the fuzz folder before `cargo +nightly fuzz run <target>`.
set -eu
tests=../crates/neuroom-core/tests
room=$tests/rooms/tiny
copy() { target=$1; shift; mkdir -p "corpus/$target"; for f in "$@"; do cp "$f" "corpus/$target/"; done; }
copy room_json "$room/room.json" "$tests"/corpus/room_*.json "$tests"/corpus/gen_huge_number.json
mkdir -p corpus/transforms_json
cp "$room/captures/box/transforms.json" corpus/transforms_json/tiny_box.json
copy transforms_json "$tests"/corpus/transforms_*.json "$tests"/corpus/gen_transforms_*.json
copy arrangement_json "$room/panoramas/p0.json" "$tests"/corpus/arrangement_*.json "$tests"/corpus/gen_arrangement_*.json
copy png_image "$room/panoramas/p0.png" "$room/panoramas/p0.depth.png" "$room/panoramas/p0.mask.png" \
    "$tests"/corpus/*.png "$tests"/corpus/*.jpg
copy envmap "$tests"/corpus/gen_envmap_* "$tests"/corpus/*.exr.js "$tests"/corpus/not_an_envmap.exr
copy ply_mesh "$room/meshes/box.ply" "$tests"/corpus/gen_ply_*.ply
