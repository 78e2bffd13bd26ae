#!/usr/bin/env bash
# Ours and OpenCV on the same homography data, in one run.
# Needs: pip install opencv-python-headless
set -euo pipefail
cd "$(dirname "$0")/../.."
cargo bench --bench homography -- --warm-up-time 1 --measurement-time 3 \
    'homography/(ransac_100_20pct_outliers|decompose)$'
python3 benches/peer/opencv_homography.py
