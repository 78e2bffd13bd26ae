#!/usr/bin/env python3
"""OpenCV peer of the `lk` bench: the same images, corners and settings.

Reads what `LK_PEER_DIR=DIR cargo bench --bench lk` wrote into DIR
(first.pgm, second.pgm, points.txt, config.txt, ours.txt), times
`cv2.calcOpticalFlowPyrLK` single-threaded (median of many runs, setup
outside the timer), computes the endpoint error of both trackers against the
ground-truth homography, reads our criterion medians from
target/criterion/*/new/estimates.json and prints one table.

Usage: opencv_lk.py DIR [--criterion target/criterion] [--runs N]
                     [--timing-only ROUNDS.json | --rounds ROUNDS.json]
Driven by benches/peer/run_lk_peer.sh.
"""
import argparse
import json
import os
import statistics
import time

import cv2
import numpy as np


def read_config(path):
    cfg = {}
    with open(path) as f:
        for line in f:
            key, value = line.split()
            cfg[key] = value
    return (int(cfg["window"]), int(cfg["levels"]), int(cfg["max_iterations"]),
            float(cfg["epsilon"]))


def median_ns(fn, runs, warmup):
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(runs):
        t0 = time.perf_counter_ns()
        fn()
        times.append(time.perf_counter_ns() - t0)
    return statistics.median(times)


def criterion_median_ns(root, name):
    path = os.path.join(root, name, "new", "estimates.json")
    try:
        with open(path) as f:
            return json.load(f)["median"]["point_estimate"]
    except OSError:
        return None


def errors(pos, ok, truth):
    d = np.linalg.norm(pos.astype(np.float64) - truth, axis=1)
    return d, ok.astype(bool)


def stats(d, ok):
    e = np.sort(d[ok])
    if len(e) == 0:
        return (0, float("inf"), float("inf"), float("inf"))
    return (int(ok.sum()), float(np.median(e)), float(np.mean(e)),
            float(np.percentile(e, 90)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--criterion", default="target/criterion")
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--timing-only", metavar="JSON",
                    help="only time OpenCV; append its medians and our latest criterion "
                         "medians to the JSON list")
    ap.add_argument("--rounds", metavar="JSON",
                    help="earlier rounds (from --timing-only): report medians over all rounds")
    args = ap.parse_args()

    cv2.setNumThreads(1)
    first = cv2.imread(os.path.join(args.dir, "first.pgm"), cv2.IMREAD_GRAYSCALE)
    second = cv2.imread(os.path.join(args.dir, "second.pgm"), cv2.IMREAD_GRAYSCALE)
    pts = np.loadtxt(os.path.join(args.dir, "points.txt"), dtype=np.float64)
    ours = np.loadtxt(os.path.join(args.dir, "ours.txt"), dtype=np.float64)
    window, levels, iterations, eps = read_config(os.path.join(args.dir, "config.txt"))
    corners = pts[:, :2].astype(np.float32).reshape(-1, 1, 2)
    truth = pts[:, 2:4]

    win = (window, window)
    max_level = levels - 1
    # OpenCV squares epsilon and compares the squared step, as ours does.
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, iterations, eps)

    def full():
        return cv2.calcOpticalFlowPyrLK(first, second, corners, None, winSize=win,
                                        maxLevel=max_level, criteria=criteria)

    # The Python binding takes images only (not prebuilt pyramids), so
    # OpenCV's tracking-only time is estimated as the full call minus its
    # two pyramid builds (the previous frame's with derivatives, as the
    # tracker computes them).
    def pyramid_with_derivatives():
        return cv2.buildOpticalFlowPyramid(first, win, max_level, withDerivatives=True)

    def pyramid():
        return cv2.buildOpticalFlowPyramid(second, win, max_level, withDerivatives=False)

    nxt, status, _ = full()

    runs = args.runs
    cv_full = median_ns(full, runs, 50)
    cv_pyr_d = median_ns(pyramid_with_derivatives, runs, 50)
    cv_pyr = median_ns(pyramid, runs, 50)
    names = ["lk_100_corners_21x21_3_levels", "lk_100_corners_21x21_3_levels_with_pyramids",
             "pyramid_build_320x240_3_levels"]
    if args.timing_only:
        # Append this round: OpenCV's medians and our latest criterion medians.
        rounds = []
        if os.path.exists(args.timing_only):
            with open(args.timing_only) as f:
                rounds = json.load(f)
        rounds.append({"opencv": {"full": cv_full, "pyr_d": cv_pyr_d, "pyr": cv_pyr},
                       "ours": {n: criterion_median_ns(args.criterion, n) for n in names}})
        with open(args.timing_only, "w") as f:
            json.dump(rounds, f)
        return
    ours_t = {n: criterion_median_ns(args.criterion, n) for n in names}
    spread = {}
    per_round = {}
    if args.rounds:
        # The machine is shared: OpenCV and our bench ran alternately in
        # several rounds; each figure is the median over the rounds.
        with open(args.rounds) as f:
            rounds = json.load(f)
        cv_all = [r["opencv"] for r in rounds] + [{"full": cv_full, "pyr_d": cv_pyr_d,
                                                   "pyr": cv_pyr}]
        ours_all = [r["ours"] for r in rounds[1:]] + [ours_t]
        med = lambda xs: statistics.median(xs)
        cv_full = med([r["full"] for r in cv_all])
        cv_pyr_d = med([r["pyr_d"] for r in cv_all])
        cv_pyr = med([r["pyr"] for r in cv_all])
        for n in names:
            vals = [r[n] for r in ours_all if r.get(n) is not None]
            ours_t[n] = med(vals) if vals else None
            spread[n] = (min(vals), max(vals)) if vals else None
        spread["opencv_full"] = (min(r["full"] for r in cv_all), max(r["full"] for r in cv_all))
        spread["rounds"] = (len(ours_all), len(cv_all))
        # Our round k ran between OpenCV's rounds k and k + 1: its ratio to
        # the mean of those two is the least disturbed by the machine's drift.
        track = lambda r: r["full"] - r["pyr_d"] - r["pyr"]
        per_round = {}
        for n, cv_of in ((names[0], track), (names[1], lambda r: r["full"])):
            ratios = [o[n] / ((cv_of(a) + cv_of(b)) / 2)
                      for o, a, b in zip(ours_all, cv_all, cv_all[1:]) if o.get(n) is not None]
            if ratios:
                per_round[n] = ratios
    cv_track = cv_full - cv_pyr_d - cv_pyr

    rows = [
        ("track, pyramids prebuilt (a)", ours_t[names[0]], cv_track),
        ("both pyramids + track", ours_t[names[1]], cv_full),
        ("one pyramid (no derivatives)", ours_t[names[2]], cv_pyr),
    ]
    print()
    print(f"Pyramidal LK, {len(corners)} corners, {window}x{window} window, {levels} levels, "
          f"{iterations} iterations / eps {eps}, {first.shape[1]}x{first.shape[0]}; "
          f"OpenCV {cv2.__version__}, 1 thread, median of {runs} calls each timed alone"
          "; ours: criterion, median of calls each timed alone"
          + (f"; median over {spread['rounds'][0]} rounds of ours alternating with "
             f"{spread['rounds'][1]} of OpenCV" if spread else ""))
    print(f"{'':32} {'ours (us)':>10} {'OpenCV (us)':>12} {'ours/OpenCV':>12}")
    for name, o, c in rows:
        o_txt = f"{o / 1e3:10.1f}" if o is not None else f"{'n/a':>10}"
        r_txt = f"{o / c:12.2f}" if o is not None else f"{'n/a':>12}"
        print(f"{name:32} {o_txt} {c / 1e3:12.1f} {r_txt}")

    if spread:
        lo, hi = spread["opencv_full"]
        print(f"spread over rounds: OpenCV full {lo / 1e3:.1f}-{hi / 1e3:.1f} us", end="")
        for n, label in zip(names, ("ours track", "ours with pyramids", "ours pyramid")):
            if spread.get(n):
                lo, hi = spread[n]
                print(f"; {label} {lo / 1e3:.1f}-{hi / 1e3:.1f} us", end="")
        print()
        for n, label in zip(names, ("track, pyramids prebuilt", "both pyramids + track")):
            ratios = per_round.get(n)
            if ratios:
                print(f"per round, ours / OpenCV's rounds either side, {label}: median "
                      f"{statistics.median(ratios):.2f}, range {min(ratios):.2f}-{max(ratios):.2f} "
                      f"({' '.join(f'{r:.2f}' for r in ratios)})")

    d_cv, ok_cv = errors(nxt.reshape(-1, 2), status.reshape(-1), truth)
    d_us, ok_us = errors(ours[:, :2], ours[:, 2], truth)
    both = ok_cv & ok_us
    print()
    print(f"Endpoint error vs ground truth (px){'':2} {'tracked':>8} {'median':>8} {'mean':>8} "
          f"{'p90':>8}   on the {int(both.sum())} tracked by both: {'median':>8} {'mean':>8}")
    for name, d, ok in (("ours", d_us, ok_us), ("OpenCV", d_cv, ok_cv)):
        n, med, mean, p90 = stats(d, ok)
        _, med_b, mean_b, _ = stats(d, both)
        print(f"{name:36} {n:8d} {med:8.4f} {mean:8.4f} {p90:8.4f}   {'':24}{med_b:8.4f} "
              f"{mean_b:8.4f}")
    print()
    print("(a) OpenCV: calcOpticalFlowPyrLK minus buildOpticalFlowPyramid of both images "
          f"(with derivatives {cv_pyr_d / 1e3:.1f} us, without {cv_pyr / 1e3:.1f} us); "
          "the Python binding cannot take prebuilt pyramids.")


if __name__ == "__main__":
    main()
