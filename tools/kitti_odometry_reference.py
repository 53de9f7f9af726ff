#!/usr/bin/env python3
"""An independent transcription of the KITTI odometry devkit's error
(evaluate_odometry.cpp: trajectoryDistances, lastFrameFromSegmentLength,
calcSequenceErrors), in plain Python without numpy, to check `vslam eval
--kitti-metrics`. Shares no code with vslam.

    kitti_odometry_reference.py GT.txt EST.txt [--scale S] [--lengths 100,200,...] [--stable-angle]
                                [--est-frames EST_frames.txt]

Both files in KITTI format, one pose per frame (line i is frame i). Prints the
number of subsequences, the mean translational error in % and the mean
rotational error in deg/100m.
"""
import argparse
import math


def read_poses(path):
    poses = []
    with open(path) as f:
        for line in f:
            v = [float(x) for x in line.split()]
            if len(v) == 12:
                poses.append([v[0:4], v[4:8], v[8:12], [0.0, 0.0, 0.0, 1.0]])
    return poses


def mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def inv(m):
    r = [[m[j][i] for j in range(3)] for i in range(3)]
    t = [-sum(r[i][k] * m[k][3] for k in range(3)) for i in range(3)]
    return [r[0] + [t[0]], r[1] + [t[1]], r[2] + [t[2]], [0.0, 0.0, 0.0, 1.0]]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("gt")
    parser.add_argument("est")
    parser.add_argument("--scale", type=float, default=1.0)
    parser.add_argument("--est-frames", help="frame index file of EST (line i of EST is frame N_i); subsequences "
                        "with an end frame missing from EST are skipped (the devkit itself needs every frame)")
    parser.add_argument("--lengths", default="100,200,300,400,500,600,700,800")
    parser.add_argument("--stable-angle", action="store_true",
                        help="angle by atan2 instead of the devkit's acos (which has a floor of ~1e-4 rad "
                             "on KITTI's 7-digit rotations)")
    args = parser.parse_args()
    gt = read_poses(args.gt)
    est = read_poses(args.est)
    if args.est_frames:
        with open(args.est_frames) as f:
            frames = [int(line) for line in f if line.strip()]
        by_frame = [None] * len(gt)
        for frame, pose in zip(frames, est):
            by_frame[frame] = pose
        est = by_frame
    assert len(gt) == len(est), "one pose per frame in both files"
    lengths = [float(x) for x in args.lengths.split(",")]
    for p in est:
        for i in range(3 if p else 0):
            p[i][3] *= args.scale
    dist = [0.0]
    for i in range(1, len(gt)):
        dist.append(dist[-1] + math.sqrt(sum((gt[i][k][3] - gt[i - 1][k][3]) ** 2 for k in range(3))))
    errors = []
    for first in range(0, len(gt), 10):
        for length in lengths:
            last = next((i for i in range(first, len(gt)) if dist[i] > dist[first] + length), -1)
            if last == -1 or est[first] is None or est[last] is None:
                continue
            delta_gt = mul(inv(gt[first]), gt[last])
            delta_est = mul(inv(est[first]), est[last])
            e = mul(inv(delta_est), delta_gt)  # the devkit's order
            d = 0.5 * (e[0][0] + e[1][1] + e[2][2] - 1.0)
            r = math.acos(max(min(d, 1.0), -1.0))
            if args.stable_angle:  # the same angle, without acos's loss of precision near 0
                w = [e[2][1] - e[1][2], e[0][2] - e[2][0], e[1][0] - e[0][1]]
                r = math.atan2(0.5 * math.sqrt(sum(x * x for x in w)), d)
            t = math.sqrt(e[0][3] ** 2 + e[1][3] ** 2 + e[2][3] ** 2)
            errors.append((t / length, r / length))
    if not errors:
        print("subsequences 0")
        return
    t_err = sum(e[0] for e in errors) / len(errors)
    r_err = sum(e[1] for e in errors) / len(errors)
    print("subsequences %d translation_pct %.12f rotation_deg_per_100m %.12f"
          % (len(errors), 100 * t_err, r_err * 180 / math.pi * 100))


if __name__ == "__main__":
    main()
