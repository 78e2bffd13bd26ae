#!/usr/bin/env bash
# Side-by-side: our pyramidal LK (criterion bench `lk`) and OpenCV's
# calcOpticalFlowPyrLK (single thread) on the same images, corners and
# settings, in one run. Needs `pip install opencv-python-headless numpy`.
# The machine is shared and its load changes by the minute, so OpenCV and our
# bench run alternately for ROUNDS rounds (default 3) and the table shows the
# median over the rounds (and the spread).
# Usage: [ROUNDS=n] benches/peer/run_lk_peer.sh [extra criterion args]
set -euo pipefail
cd "$(dirname "$0")/../.."
rounds=${ROUNDS:-3}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
target=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
crit="$target/criterion"
benches='^(lk/100_corners_21x21_3_levels|lk/100_corners_21x21_3_levels_with_pyramids|pyramid/build_320x240_3_levels)$'
# Build, and write the shared input (no bench matches this filter).
LK_PEER_DIR="$dir" cargo bench --bench lk -- '^write-inputs-only$' > /dev/null
for _ in $(seq "$rounds"); do
    python3 benches/peer/opencv_lk.py "$dir" --criterion "$crit" --timing-only "$dir/rounds.json"
    cargo bench --bench lk -- --warm-up-time 1 --measurement-time 3 "$benches" "$@"
done
python3 benches/peer/opencv_lk.py "$dir" --criterion "$crit" --rounds "$dir/rounds.json"
