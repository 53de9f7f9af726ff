#!/usr/bin/env python3
"""Writes a deterministic, perturbed copy of a TUM trajectory, for checking
`vslam eval` against tools/evaluate_ate_reference.py (docs/EVALUATION.md).

    make_perturbed_trajectory.py GROUNDTRUTH OUTPUT [--scale 0.5]

Pose k of the output is ground-truth pose 3k (so ~33 Hz from 100 Hz), with
  timestamp  t + 0.004 s
  position   s * R * (p + n_k) + t0,   n_k = 0.01 m * (sin(12.9898 k), sin(78.233 k + 1), sin(37.719 k + 2))
  rotation   R * R_k
where R is 30 degrees about the axis (1, 2, 3), t0 = (0.4, -1.2, 2.0) m and s
is --scale (0.5 by default, like a monocular run's arbitrary scale).
Pure Python (no numpy) so the formula is plain to read.
"""
import argparse
import math


def quaternion_to_matrix(qx, qy, qz, qw):
    n = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    x, y, z, w = qx / n, qy / n, qz / n, qw / n
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def matrix_to_quaternion(m):
    # Shepperd's method: pick the largest of w, x, y, z to divide by.
    trace = m[0][0] + m[1][1] + m[2][2]
    if trace > 0:
        s = 2 * math.sqrt(trace + 1)
        return ((m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, s / 4)
    if m[0][0] > m[1][1] and m[0][0] > m[2][2]:
        s = 2 * math.sqrt(1 + m[0][0] - m[1][1] - m[2][2])
        return (s / 4, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s)
    if m[1][1] > m[2][2]:
        s = 2 * math.sqrt(1 + m[1][1] - m[0][0] - m[2][2])
        return ((m[0][1] + m[1][0]) / s, s / 4, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s)
    s = 2 * math.sqrt(1 + m[2][2] - m[0][0] - m[1][1])
    return ((m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, s / 4, (m[1][0] - m[0][1]) / s)


def axis_angle(axis, degrees):
    n = math.sqrt(sum(a * a for a in axis))
    half = math.radians(degrees) / 2
    x, y, z = (a / n * math.sin(half) for a in axis)
    return quaternion_to_matrix(x, y, z, math.cos(half))


def mat_mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def mat_vec(a, v):
    return [sum(a[i][k] * v[k] for k in range(3)) for i in range(3)]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("groundtruth")
    parser.add_argument("output")
    parser.add_argument("--scale", type=float, default=0.5)
    args = parser.parse_args()

    poses = []
    with open(args.groundtruth) as f:
        for line in f:
            if line.strip() and not line.lstrip().startswith("#"):
                poses.append([float(v) for v in line.split()])

    R = axis_angle((1.0, 2.0, 3.0), 30.0)
    t0 = (0.4, -1.2, 2.0)
    with open(args.output, "w") as out:
        out.write("# perturbed copy of %s (tools/make_perturbed_trajectory.py, scale %g)\n" % (args.groundtruth, args.scale))
        for k, pose in enumerate(poses[::3]):
            stamp, p, q = pose[0], pose[1:4], pose[4:8]
            noise = (0.01 * math.sin(12.9898 * k), 0.01 * math.sin(78.233 * k + 1), 0.01 * math.sin(37.719 * k + 2))
            moved = mat_vec(R, [p[i] + noise[i] for i in range(3)])
            position = [args.scale * moved[i] + t0[i] for i in range(3)]
            rotation = mat_mul(R, quaternion_to_matrix(*q))
            qx, qy, qz, qw = matrix_to_quaternion(rotation)
            out.write("%.6f %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n" % (stamp + 0.004, *position, qx, qy, qz, qw))


if __name__ == "__main__":
    main()
