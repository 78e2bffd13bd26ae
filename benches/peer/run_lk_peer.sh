#!/usr/bin/env bash
# Side-by-side: our pyramidal LK (criterion bench `lk`) and OpenCV's
# calcOpticalFlowPyrLK (single thread) on the same images, corners and
# settings, in one run. Needs `pip install opencv-python-headless numpy`.
# Usage: benches/peer/run_lk_peer.sh [extra criterion args]
set -euo pipefail
cd "$(dirname "$0")/../.."
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
target=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
LK_PEER_DIR="$dir" cargo bench --bench lk -- --warm-up-time 1 --measurement-time 3 \
    '^(lk/100_corners_21x21_3_levels|lk/100_corners_21x21_3_levels_with_pyramids|pyramid/build_320x240_3_levels)$' "$@"
python3 benches/peer/opencv_lk.py "$dir" --criterion "$target/criterion"
