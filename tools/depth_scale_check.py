#!/usr/bin/python3
"""Checks a TUM RGB-D sequence's depth scale against its ground truth.

Frame pairs with a ground-truth baseline of at least --min-baseline metres are
matched (cv::ORB, cross-checked, kept within --max-epipolar px of the epipolar
line the ground truth gives); each match is triangulated with the two
ground-truth poses, and the depth image's reading at the keypoint is divided
by the triangulated depth. A median ratio of 1 means the depth images and the
motion-capture trajectory agree on scale; 0.99 means the depth reads 1 % short,
so any RGB-D map built from it comes out 1 % small. Nothing of vslam is used:
the check is independent of the SLAM system it explains. The depth image is
taken as seen at its colour frame's time (they are paired within 20 ms), as
vslam pairs them; in fast motion that adds noise to the ratios.

  tools/depth_scale_check.py --seq ../shared/data/tum/rgbd_dataset_freiburg3_teddy \
      --intrinsics 535.4 539.2 320.1 247.6

Needs python3-numpy and python3-opencv (Debian packages; tools/setup.sh installs them).
"""
import argparse
import bisect
import os
import sys

import cv2
import numpy as np


def fail(message):
    sys.exit(f'depth_scale_check: {message}')


def read_list(path, values):
    """A TUM list: 'timestamp' and `values` more fields a line, '#' comments."""
    if not os.path.isfile(path):
        fail(f'{path}: no such file')
    entries = []
    with open(path) as f:
        for number, line in enumerate(f, 1):
            if line.startswith('#') or not line.strip():
                continue
            parts = line.split()
            if len(parts) != 1 + values:
                fail(f'{path}:{number}: expected {1 + values} fields, found {len(parts)}')
            try:
                entries.append((float(parts[0]), parts[1:]))
            except ValueError:
                fail(f'{path}:{number}: the timestamp {parts[0]!r} is not a number')
    if not entries:
        fail(f'{path}: no entries')
    return entries


def quat_to_matrix(qx, qy, qz, qw):
    q = np.array([qw, qx, qy, qz]) / np.linalg.norm([qw, qx, qy, qz])
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


class GroundTruth:
    def __init__(self, path):
        rows = []
        for t, values in read_list(path, 7):  # tx ty tz qx qy qz qw
            try:
                rows.append((t, [float(v) for v in values]))
            except ValueError:
                fail(f'{path}: a pose at {t} has a value that is not a number')
        self.times = [t for t, _ in rows]
        self.poses = [v for _, v in rows]
        # Interpolation bridges the trajectory's own spacing (10 ms for TUM's
        # 100 Hz motion capture, 33 ms for `vslam synth`'s 30 Hz), not a gap
        # where the tracking markers were lost.
        spacing = float(np.median(np.diff(self.times))) if len(self.times) > 1 else 0.0
        self.max_gap = max(0.02, 1.5 * spacing)

    def camera_to_world(self, t):
        """Pose at t by linear interpolation (translation) and normalised lerp
        (rotation) between the two nearest poses; None across a gap wider than max_gap."""
        k = bisect.bisect_left(self.times, t)
        if k == 0 or k == len(self.times):
            return None
        t0, t1 = self.times[k - 1], self.times[k]
        if t1 - t0 > self.max_gap:
            return None
        a = (t - t0) / (t1 - t0)
        p0, p1 = np.array(self.poses[k - 1]), np.array(self.poses[k])
        q0, q1 = p0[3:], p1[3:]
        if np.dot(q0, q1) < 0:
            q1 = -q1
        q = (1 - a) * q0 + a * q1
        T = np.eye(4)
        T[:3, :3] = quat_to_matrix(*q)
        T[:3, 3] = (1 - a) * p0[:3] + a * p1[:3]
        return T


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--seq', required=True, help='TUM sequence folder (rgb.txt, depth.txt, groundtruth.txt)')
    parser.add_argument('--intrinsics', nargs=4, type=float, required=True, metavar=('FX', 'FY', 'CX', 'CY'))
    parser.add_argument('--distortion', nargs=5, type=float, default=[0, 0, 0, 0, 0], metavar=('K1', 'K2', 'P1', 'P2', 'K3'))
    parser.add_argument('--depth-factor', type=float, default=5000.0)
    parser.add_argument('--min-baseline', type=float, default=0.2, help='m between the two frames of a pair')
    parser.add_argument('--min-parallax', type=float, default=4.0, help='deg at the triangulated point')
    parser.add_argument('--max-epipolar', type=float, default=1.0, help='px from the ground-truth epipolar line')
    parser.add_argument('--stride', type=int, default=5, help='take every N-th colour frame as a pair start')
    parser.add_argument('--time-offset', default='auto',
                        help="s added to colour timestamps before the ground-truth lookup, or 'auto' (default)")
    parser.add_argument('--depth-bins', nargs='+', type=float, default=[0, 1.0, 1.5, 2.0, 3.0, 10.0], metavar='M',
                        help='edges of the depth bins the ratio is also given for, m, increasing (default: 0 1 1.5 2 3 10)')
    args = parser.parse_args()
    if args.stride < 1 or args.depth_factor <= 0 or args.min_baseline <= 0:
        fail('--stride must be >= 1, --depth-factor and --min-baseline > 0')
    edges = args.depth_bins
    if len(edges) < 2 or any(hi <= lo for lo, hi in zip(edges, edges[1:])) or edges[0] < 0:
        fail(f'--depth-bins {" ".join(f"{e:g}" for e in edges)}: give at least two edges, >= 0 and increasing')

    fx, fy, cx, cy = args.intrinsics
    K = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]])
    dist = np.array(args.distortion)
    rgb = read_list(os.path.join(args.seq, 'rgb.txt'), 1)
    depth = read_list(os.path.join(args.seq, 'depth.txt'), 1)
    depth_times = [t for t, _ in depth]
    gt = GroundTruth(os.path.join(args.seq, 'groundtruth.txt'))

    # Colour frames with a depth image within 20 ms, by timestamp.
    paired = []
    for t, (name,) in rgb:
        k = bisect.bisect_left(depth_times, t)
        near = [j for j in (k - 1, k) if 0 <= j < len(depth)]
        if near:
            j = min(near, key=lambda j: abs(depth_times[j] - t))
            if abs(depth_times[j] - t) <= 0.02:
                paired.append((t, name, depth[j][1][0]))

    orb = cv2.ORB_create(2000)
    matcher = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=True)
    features_of, matches_of, depth_of = {}, {}, {}

    def features(name):
        if name not in features_of:
            image = cv2.imread(os.path.join(args.seq, name), cv2.IMREAD_GRAYSCALE)
            if image is None:
                fail(f'{os.path.join(args.seq, name)}: cannot be read as an image')
            keypoints, descriptors = orb.detectAndCompute(image, None)
            pixels = np.array([kp.pt for kp in keypoints], dtype=np.float64).reshape(-1, 1, 2)
            # Undistorted pixels: the depth image is registered to the pinhole model.
            undistorted = cv2.undistortPoints(pixels, K, dist, P=K).reshape(-1, 2) if len(keypoints) else pixels.reshape(-1, 2)
            features_of[name] = (undistorted, descriptors)
        return features_of[name]

    def matched(name_i, name_j):
        if (name_i, name_j) not in matches_of:
            ui, di = features(name_i)
            uj, dj = features(name_j)
            matches = matcher.match(di, dj) if di is not None and dj is not None else []
            matches_of[(name_i, name_j)] = (np.array([ui[m.queryIdx] for m in matches]).reshape(-1, 2),
                                            np.array([uj[m.trainIdx] for m in matches]).reshape(-1, 2))
        return matches_of[(name_i, name_j)]

    def depth_image(name):
        if name not in depth_of:
            path = os.path.join(args.seq, name)
            raw = cv2.imread(path, cv2.IMREAD_UNCHANGED)
            if raw is None:
                fail(f'{path}: cannot be read as an image')
            if raw.dtype != np.uint16 or raw.ndim != 2:
                fail(f'{path}: not a 16-bit single-channel depth image (TUM format)')
            depth_of[name] = raw.astype(np.float64) / args.depth_factor
        return depth_of[name]

    # The frame pairs are chosen once, from the ground truth at the colour
    # frames' own times: every clock offset tried below is then judged on the
    # same pairs and the same matches.
    def choose_pairs():
        """(t_i, t_j, colour i, colour j, depth i) for each pair start."""
        frames = [(t, name, depth_name, gt.camera_to_world(t)) for t, name, depth_name in paired]
        frames = [f for f in frames if f[3] is not None]
        chosen = []
        for i in range(0, len(frames), args.stride):
            centre_i = frames[i][3][:3, 3]
            j = next((j for j in range(i + 1, len(frames))
                      if np.linalg.norm(frames[j][3][:3, 3] - centre_i) >= args.min_baseline), None)
            if j is not None:
                chosen.append((frames[i][0], frames[j][0], frames[i][1], frames[j][1], frames[i][2]))
        return chosen

    frame_pairs = choose_pairs()
    if not paired:
        fail(f'{args.seq}: no colour frame in rgb.txt has a depth image in depth.txt within 20 ms')
    if not frame_pairs:
        fail(f'{args.seq}: no two frames with ground truth at their times are --min-baseline '
             f'{args.min_baseline} m apart (colour frames {paired[0][0]:.3f}-{paired[-1][0]:.3f} s, ground truth '
             f'{gt.times[0]:.3f}-{gt.times[-1]:.3f} s, gaps over {1000 * gt.max_gap:.0f} ms not bridged)')

    def pairs_at(offset):
        """(colour i, colour j, depth i, T_ji) for each chosen pair, ground truth looked up at t + offset."""
        pairs = []
        for t_i, t_j, name_i, name_j, depth_name in frame_pairs:
            T_i, T_j = gt.camera_to_world(t_i + offset), gt.camera_to_world(t_j + offset)
            if T_i is not None and T_j is not None:
                pairs.append((name_i, name_j, depth_name, np.linalg.inv(T_j) @ T_i))
        return pairs

    def epipolar_distances(a, b, T_ji):
        R, t = T_ji[:3, :3], T_ji[:3, 3]
        tx = np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])
        F = np.linalg.inv(K).T @ tx @ R @ np.linalg.inv(K)
        lines = np.hstack([a, np.ones((len(a), 1))]) @ F.T  # epipolar lines in image j
        return np.abs(np.sum(lines * np.hstack([b, np.ones((len(b), 1))]), axis=1)) / np.linalg.norm(lines[:, :2], axis=1)

    # The matches the offsets are judged on: those within 5 --max-epipolar of
    # their epipolar line at offset 0 (the rest are wrong matches at any offset).
    judged = {}
    for name_i, name_j, _, T_ji in pairs_at(0.0):
        a, b = matched(name_i, name_j)
        if len(a):
            keep = epipolar_distances(a, b, T_ji) < 5 * args.max_epipolar
            if keep.any():
                judged[(name_i, name_j)] = (a[keep], b[keep])

    def median_epipolar(offset):
        distances = []
        for name_i, name_j, _, T_ji in pairs_at(offset):
            if (name_i, name_j) in judged:
                distances.extend(epipolar_distances(*judged[(name_i, name_j)], T_ji))
        return np.median(distances) if distances else np.inf

    # Colour and motion-capture clocks differ by a few milliseconds; at 1 m/s
    # that moves a 0.2 m baseline by 5 %. The offset that best fits the
    # epipolar geometry of all matches is taken (a grid of 2.5 ms).
    if args.time_offset == 'auto':
        grid = [k * 0.0025 for k in range(-12, 13)]
        scores = [median_epipolar(offset) for offset in grid]
        offset = grid[int(np.argmin(scores))]
        if offset in (grid[0], grid[-1]):
            print(f'warning: the best clock offset is at the edge of the +-30 ms searched; give --time-offset')
        print(f'time offset: {offset * 1000:+.1f} ms (median epipolar distance {min(scores):.3f} px; '
              f'{scores[grid.index(0.0)]:.3f} px at 0)')
    else:
        try:
            offset = float(args.time_offset)
        except ValueError:
            fail(f"--time-offset: {args.time_offset!r} is neither seconds nor 'auto'")

    ratios, depths, n_pairs = [], [], 0  # n_pairs: pairs that gave at least one point
    for name_i, name_j, depth_name, T_ji in pairs_at(offset):
        a, b = matched(name_i, name_j)
        if not len(a):
            continue
        keep = epipolar_distances(a, b, T_ji) < args.max_epipolar
        if not keep.any():
            continue
        a, b = a[keep], b[keep]
        R, t = T_ji[:3, :3], T_ji[:3, 3]
        P_i = K @ np.hstack([np.eye(3), np.zeros((3, 1))])
        P_j = K @ np.hstack([R, t.reshape(3, 1)])
        X = cv2.triangulatePoints(P_i, P_j, a.T, b.T)
        X = (X[:3] / X[3]).T  # in camera i
        centre_j = -R.T @ t
        image = depth_image(depth_name)
        before = len(ratios)
        for p, x in zip(a, X):
            if x[2] <= 0:
                continue
            ray_j = x - centre_j
            cos = np.dot(x, ray_j) / (np.linalg.norm(x) * np.linalg.norm(ray_j))
            if np.degrees(np.arccos(np.clip(cos, -1, 1))) < args.min_parallax:
                continue
            c, r = int(round(p[0])), int(round(p[1]))
            if not (1 <= r < image.shape[0] - 1 and 1 <= c < image.shape[1] - 1):
                continue
            window = image[r - 1:r + 2, c - 1:c + 2]
            d = image[r, c]
            # Depth edges give either side's depth: only smooth patches are compared.
            if d <= 0 or (window <= 0).any() or window.max() - window.min() > 0.02 * d:
                continue
            ratios.append(d / x[2])
            depths.append(d)
        n_pairs += len(ratios) > before

    ratios, depths = np.array(ratios), np.array(depths)
    if len(ratios) == 0:
        sys.exit('depth_scale_check: no point passed the checks')
    print(f'sequence: {args.seq}')
    print(f'pairs: {n_pairs}, points: {len(ratios)}, depth {np.percentile(depths, 5):.2f}-{np.percentile(depths, 95):.2f} m (5-95 %)')
    q1, med, q3 = np.percentile(ratios, [25, 50, 75])
    half = len(ratios) // 2
    print(f'depth reading / triangulated depth: median {med:.4f} (quartiles {q1:.4f}-{q3:.4f}); '
          f'first half of the points (by time) {np.median(ratios[:half]):.4f}, second half {np.median(ratios[half:]):.4f}')
    # As many decimals as the edges need (at least one): 0.75 must not print as 0.8.
    decimals = max([1] + [len(f'{e:g}'.partition('.')[2]) for e in edges])
    for lo, hi in zip(edges, edges[1:]):
        sel = (depths >= lo) & (depths < hi)
        if sel.sum() >= 20:
            print(f'  depth {lo:.{decimals}f}-{hi:.{decimals}f} m: median {np.median(ratios[sel]):.4f} over {sel.sum()} points')
    print(f'depth factor that would make them agree: {args.depth_factor * med:.0f} (given {args.depth_factor:g})')


if __name__ == '__main__':
    main()
