#!/usr/bin/env python3
"""OpenCV peer of `benches/homography.rs`, on exactly the same data.

Reads `target/peer/homography_scene.txt` (written by `cargo bench --bench homography`),
times OpenCV single-threaded on it and prints one table with our criterion
medians (read from `target/criterion/homography/*/new/estimates.json`), the peer's
median, the ratio (ours / OpenCV; below 1 means ours is faster) and the inlier sets.

Run both with `benches/peer/run_homography_peer.sh`; this script alone only
re-reads the last bench results.
"""

import json
import os
import sys
import time

import cv2
import numpy as np

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
TARGET = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
SCENE = os.path.join(ROOT, "target", "peer", "homography_scene.txt")


def read_scene(path):
    k = h = thr = None
    rows = []
    with open(path) as f:
        for line in f:
            parts = line.split()
            if parts[0] == "K":
                fx, fy, cx, cy = map(float, parts[1:])
                k = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]], dtype=np.float64)
            elif parts[0] == "H":
                h = np.array(list(map(float, parts[1:])), dtype=np.float64).reshape(3, 3)
            elif parts[0] == "threshold":
                thr = float(parts[1])
            else:
                rows.append(list(map(float, parts)))
    a = np.array(rows)
    return k, h, thr, a[:, 0:2].astype(np.float32), a[:, 2:4].astype(np.float32), a[:, 4] > 0.5, a[:, 5] > 0.5


def median_time_us(fn, reps, rounds=7):
    """Median over `rounds` of the mean time of `reps` calls, in microseconds."""
    fn()
    samples = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(reps):
            fn()
        samples.append((time.perf_counter() - t0) / reps * 1e6)
    return float(np.median(samples))


def ours_us(name):
    path = os.path.join(TARGET, "criterion", "homography_" + name, "new", "estimates.json")
    try:
        with open(path) as f:
            return json.load(f)["median"]["point_estimate"] / 1000.0
    except (OSError, KeyError, ValueError):
        return None


def main():
    cv2.setNumThreads(1)
    k, h_true, thr, p1, p2, truth, ours = read_scene(SCENE)
    n = len(p1)

    def ransac():
        return cv2.findHomography(p1, p2, cv2.RANSAC, thr, maxIters=2000, confidence=0.995)

    def magsac():
        return cv2.findHomography(p1, p2, cv2.USAC_MAGSAC, thr, maxIters=2000, confidence=0.995)

    _, m_ransac = ransac()
    _, m_magsac = magsac()
    m_ransac = m_ransac.ravel() > 0
    m_magsac = m_magsac.ravel() > 0
    t_ransac = median_time_us(ransac, 200)
    t_magsac = median_time_us(magsac, 200)
    h64 = h_true / h_true[2, 2]
    t_dec = median_time_us(lambda: cv2.decomposeHomographyMat(h64, k), 20000)

    def same(a, b):
        return int(np.sum(a == b))

    print(f"scene: {n} matches, {int(truth.sum())} true inliers, threshold {thr} px")
    print(f"inlier sets equal to the truth on: ours {same(ours, truth)}/{n}, "
          f"OpenCV RANSAC {same(m_ransac, truth)}/{n}, USAC_MAGSAC {same(m_magsac, truth)}/{n}")
    print(f"ours vs OpenCV RANSAC inlier set: {same(ours, m_ransac)}/{n} equal")
    print()
    rows = [
        ("RANSAC homography, 100 matches, 20 % outliers", ours_us("ransac_100_20pct_outliers"),
         "findHomography RANSAC", t_ransac, "<= 100 us"),
        ("same, vs USAC_MAGSAC", ours_us("ransac_100_20pct_outliers"),
         "findHomography USAC_MAGSAC", t_magsac, "<= 100 us"),
        ("homography decomposition", ours_us("decompose"),
         "decomposeHomographyMat", t_dec, "<= 5 us"),
    ]
    print("| benchmark | ours (us) | peer | peer (us) | ours / peer | limit |")
    print("|---|---|---|---|---|---|")
    for name, o, peer, p, limit in rows:
        os_ = f"{o:.2f}" if o is not None else "n/a (run cargo bench --bench homography)"
        ratio = f"{o / p:.2f}" if o is not None else "n/a"
        print(f"| {name} | {os_} | {peer} | {p:.2f} | {ratio} | {limit} |")
    print()
    print(f"OpenCV {cv2.__version__}, numpy {np.__version__}, single thread")
    return 0


if __name__ == "__main__":
    sys.exit(main())
