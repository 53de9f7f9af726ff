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
        [--steps-from-groundtruth W [--rescale-pairs A:B]]

With --segment N it also gives the RMSE of each run of N consecutive pairs
(in time order) under the one alignment of the whole trajectory, to show
where along a run the error lies.

With --steps-from-groundtruth W it also gives the ATE that is left when the
estimate's scale drift is taken out (a diagnostic, not a benchmark figure):
each step between consecutive pairs is rescaled by the ground truth's path
length over the estimate's, both summed over the steps within W // 2 of it
(W + 1 steps for an even W), the path is summed again from the first pair,
and aligned with a scale. With
--rescale-pairs A:B only the steps from pair A to pair B are rescaled so; the
others are rescaled by the whole run's ratio.

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


def steps_from_groundtruth(est, gt, window, first, last):
    """est, gt: 3xN. The estimate with its steps' lengths taken from the ground
    truth (see the module's docstring); steps outside [first, last) keep the
    whole run's ratio."""
    est_steps, gt_steps = np.diff(est, axis=1), np.diff(gt, axis=1)
    est_lengths = np.linalg.norm(est_steps, axis=0)
    gt_lengths = np.linalg.norm(gt_steps, axis=0)
    ratios = np.full(est_steps.shape[1], gt_lengths.sum() / est_lengths.sum())
    half = window // 2
    for i in range(max(0, first), min(last, est_steps.shape[1])):
        lo, hi = max(0, i - half), i + half + 1
        ratios[i] = gt_lengths[lo:hi].sum() / est_lengths[lo:hi].sum()
    path = np.cumsum(est_steps * ratios, axis=1)
    return np.hstack([est[:, :1], est[:, :1] + path])


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("groundtruth")
    parser.add_argument("estimate")
    parser.add_argument("--scale", action="store_true", help="also estimate a scale (Sim(3))")
    parser.add_argument("--max-difference", type=float, default=0.02)
    parser.add_argument("--segment", type=int, default=0,
                        help="also the RMSE of every N consecutive pairs, under the whole run's alignment")
    parser.add_argument("--steps-from-groundtruth", type=int, default=0, metavar="W",
                        help="also the ATE with each step's length from the ground truth (steps within W // 2)")
    parser.add_argument("--rescale-pairs", default="", metavar="A:B",
                        help="with --steps-from-groundtruth: only the steps from pair A to pair B")
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
    if args.steps_from_groundtruth > 0:
        first, last = 0, est.shape[1]
        if args.rescale_pairs:
            first, last = (int(v) for v in args.rescale_pairs.split(":"))
        rescaled = steps_from_groundtruth(est, gt, args.steps_from_groundtruth, first, last)
        r_scale, r_rotation, r_translation = horn_alignment(rescaled, gt, True)
        r_errors = np.sqrt(np.sum((r_scale * r_rotation @ rescaled + r_translation - gt) ** 2, axis=0))
        figures["steps_from_groundtruth"] = {
            "window": args.steps_from_groundtruth,
            "steps_rescaled": [first, min(last, est.shape[1] - 1)],
            "rmse_m": float(np.sqrt(np.mean(r_errors ** 2))),
        }
    print(json.dumps(figures, indent=2))


if __name__ == "__main__":
    main()
