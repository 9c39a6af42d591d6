#!/usr/bin/env bash
# Renders every room of the external validation suite with Blender Cycles (see make_room.py):
#   tools/suite/make_suite.sh [--objects-in-room] [OUT=suite] [ROOM...]
# With --objects-in-room it renders only each room's in_room/ folder (every object captured standing
# in the room, for `neuroom bench masks`), next to a room already rendered.
# Needs the Debian packages blender, blender-data, python3-numpy and sweethome3d-furniture.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
extra=()
if [ "${1:-}" = "--objects-in-room" ]; then
  extra=(--objects-in-room)
  shift
fi
out="${1:-suite}"
shift || true
rooms=("$@")
if [ ${#rooms[@]} -eq 0 ]; then
  rooms=($(cd "$here/rooms" && ls *.json | sed 's/\.json$//'))
fi
for room in "${rooms[@]}"; do
  echo "== $room"
  log="$(mktemp)"
  if ! blender -b --python-exit-code 1 -P "$here/make_room.py" -- \
      --config "$here/rooms/$room.json" --out "$out/$room" "${extra[@]}" > "$log" 2>&1; then
    tail -n 30 "$log" >&2
    echo "$room: the render failed (log above)" >&2
    exit 1
  fi
  grep '^\[suite\]' "$log" || true
  rm -f "$log"
done
