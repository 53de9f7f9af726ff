#!/usr/bin/python3
"""Independent reference for `vslam eval`'s ATE, written from the TUM RGB-D
benchmark's definition of evaluate_ate (Sturm et al. 2012):

 1. read both files ("timestamp tx ty tz qx qy qz qw", '#' comments);
 2. associate like associate.py: all (gt, est) pairs with |t_gt - t_est| < max_difference,
    sorted by that difference, taken greedily so that each stamp is used once;
 3. align the estimate's positions to the ground truth's with Horn's closed form
    (SVD of the cross-covariance; with --scale also the scale, as Umeyama 1991);
 4. error of pair i = |gt_i - (s R est_i + t)|; report RMSE, mean, median, std
    (population), min, max, the scale and the number of pairs.

    /usr/bin/python3 tools/evaluate_ate_reference.py GT EST [--scale] [--max-difference 0.02] [--segment N]

With --segment N it also gives the RMSE of each run of N consecutive pairs
(in time order) under the one alignment of the whole trajectory, to show
where along a run the error lies.

Needs numpy (Debian: apt-get install python3-numpy). Prints JSON.
"""
import argparse
import json

import numpy as np


def read_trajectory(path):
    stamps, positions = [], []
    with open(path) as f:
        for line in f:
            text = line.strip()
            if not text or text.startswith("#"):
                continue
            values = [float(v) for v in text.replace(",", " ").split()]
            stamps.append(values[0])
            positions.append(values[1:4])
    return np.array(stamps), np.array(positions)


def associate(gt_stamps, est_stamps, max_difference):
    candidates = []
    for g, tg in enumerate(gt_stamps):
        near = np.nonzero(np.abs(est_stamps - tg) < max_difference)[0]
        candidates.extend((abs(tg - est_stamps[e]), tg, est_stamps[e], g, e) for e in near)
    candidates.sort()
    gt_free, est_free = set(range(len(gt_stamps))), set(range(len(est_stamps)))
    matches = []
    for _, _, _, g, e in candidates:
        if g in gt_free and e in est_free:
            gt_free.discard(g)
            est_free.discard(e)
            matches.append((g, e))
    matches.sort()
    return matches


def horn_alignment(est, gt, with_scale):
    """s, R, t minimising sum |gt_i - (s R est_i + t)|^2; est and gt are 3xN."""
    est_mean = est.mean(axis=1, keepdims=True)
    gt_mean = gt.mean(axis=1, keepdims=True)
    est_c, gt_c = est - est_mean, gt - gt_mean
    cross = gt_c @ est_c.T  # sum of gt_c_i est_c_i^T
    u, _, vt = np.linalg.svd(cross)
    d = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        d[2, 2] = -1  # a reflection would fit better; take the best rotation instead
    rotation = u @ d @ vt
    scale = 1.0
    if with_scale:
        scale = float(np.sum(gt_c * (rotation @ est_c)) / np.sum(est_c * est_c))
    translation = gt_mean - scale * rotation @ est_mean
    return scale, rotation, translation


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("groundtruth")
    parser.add_argument("estimate")
    parser.add_argument("--scale", action="store_true", help="also estimate a scale (Sim(3))")
    parser.add_argument("--max-difference", type=float, default=0.02)
    parser.add_argument("--segment", type=int, default=0,
                        help="also the RMSE of every N consecutive pairs, under the whole run's alignment")
    args = parser.parse_args()

    gt_stamps, gt_xyz = read_trajectory(args.groundtruth)
    est_stamps, est_xyz = read_trajectory(args.estimate)
    matches = associate(gt_stamps, est_stamps, args.max_difference)
    gt = np.array([gt_xyz[g] for g, _ in matches]).T
    est = np.array([est_xyz[e] for _, e in matches]).T
    scale, rotation, translation = horn_alignment(est, gt, args.scale)
    errors = np.sqrt(np.sum((scale * rotation @ est + translation - gt) ** 2, axis=0))
    figures = {
        "rmse_m": float(np.sqrt(np.mean(errors ** 2))),
        "mean_m": float(np.mean(errors)),
        "median_m": float(np.median(errors)),
        "std_m": float(np.std(errors)),
        "min_m": float(np.min(errors)),
        "max_m": float(np.max(errors)),
        "scale": scale,
        "pairs": len(matches),
    }
    if args.segment > 0:
        figures["segments"] = [{
            "first_gt_stamp": float(gt_stamps[matches[k][0]]),
            "pairs": len(errors[k:k + args.segment]),
            "rmse_m": float(np.sqrt(np.mean(errors[k:k + args.segment] ** 2))),
        } for k in range(0, len(errors), args.segment)]
    print(json.dumps(figures, indent=2))


if __name__ == "__main__":
    main()
