#!/bin/sh
# Runs every fuzz target for SECONDS (default 600) one after another, logging to logs/<target>.log.
# Crashing inputs land in artifacts/<target>/. Run from the fuzz folder after ./seed.sh.
set -u
seconds=${1:-600}
mkdir -p logs
for target in room_json transforms_json arrangement_json png_image envmap ply_mesh; do
    cargo +nightly fuzz run -O "$target" "corpus/$target" -- -max_total_time="$seconds" \
        > "logs/$target.log" 2>&1
    echo "$target: exit $? after $(tail -n 1 "logs/$target.log")"
done
