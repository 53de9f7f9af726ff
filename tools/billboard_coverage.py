#!/usr/bin/python3
"""How much of `vslam synth --moving-object`'s billboard the detector's boxes cover.

The billboard's pixels are those where the moving room differs from the static
room rendered with the same seed (same camera path, same texture). The
detector (`vslam detect`) is run on every --every-th frame of the moving room
between --first and --last, and for each frame with a box of --class the
share of billboard pixels outside every such box is reported, boxes widened
by --margin of their size on each side. A share of 0 means the boxes mark the
whole moving object; keypoints on the rest count as static scene to the
motion check of --moving-classes.

  tools/billboard_coverage.py --moving ROOM_WITH_BILLBOARD --static ROOM [--margin 0.1]

The rooms come from `vslam synth --out DIR --seed S ...` with and without
--moving-object (tools/bench_moving_room.sh renders both, as static-S and
moving-S in its output folder). Needs python3-numpy and python3-opencv
(Debian packages; tools/setup.sh installs them) and a built build/vslam.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import cv2
import numpy as np


def fail(message):
    sys.exit(f'billboard_coverage: {message}')


def frame_files(room):
    listing = os.path.join(room, 'rgb.txt')
    try:
        with open(listing) as file:
            lines = [line.split() for line in file if line.strip() and not line.startswith('#')]
    except OSError as error:
        fail(f'{listing}: {error.strerror}')
    return [os.path.join(room, fields[1]) for fields in lines]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--moving', required=True, help='room rendered with --moving-object')
    parser.add_argument('--static', required=True, help='the same room (same seed) without it')
    parser.add_argument('--first', type=int, default=60, help='first frame (default 60: the billboard starts moving)')
    parser.add_argument('--last', type=int, default=210, help='last frame (default 210)')
    parser.add_argument('--every', type=int, default=5, help='every n-th frame (default 5)')
    parser.add_argument('--margin', type=float, action='append',
                        help='widen boxes by this share of their size on each side (repeatable; default 0)')
    parser.add_argument('--class', dest='class_name', default='person', help="boxes of this class (default person)")
    parser.add_argument('--vslam', default='build/vslam', help='the vslam binary (default build/vslam)')
    args = parser.parse_args()
    margins = args.margin or [0.0]

    moving, static = frame_files(args.moving), frame_files(args.static)
    if len(moving) != len(static):
        fail(f'{args.moving} has {len(moving)} frames and {args.static} {len(static)}: not the same room')
    picked = list(range(args.first, min(args.last, len(moving) - 1) + 1, args.every))
    if not picked:
        fail(f'no frame between {args.first} and {args.last}')

    with tempfile.TemporaryDirectory() as out:
        command = [args.vslam, 'detect', '--out', out, '--images'] + [moving[k] for k in picked]
        run = subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if run.returncode != 0:
            fail(f'{" ".join(command[:4])} failed: {run.stderr.strip()}')
        with open(os.path.join(out, 'detections.json')) as file:
            detected = {image['file']: image['detections'] for image in json.load(file)['images']}

    frames = []  # (billboard mask, boxes) of the frames with a box
    for k in picked:
        with_billboard, without = cv2.imread(moving[k]), cv2.imread(static[k])
        if with_billboard is None or without is None:
            fail(f'cannot read {moving[k]} or {static[k]}')
        billboard = np.abs(with_billboard.astype(int) - without.astype(int)).sum(axis=2) > 30
        boxes = [d['box'] for d in detected.get(moving[k], []) if d['class'] == args.class_name]
        if billboard.sum() >= 200 and boxes:
            frames.append((billboard, boxes))
    print(f'{len(frames)} of {len(picked)} frames show the billboard and a {args.class_name} box')
    if not frames:
        return
    for margin in margins:
        outside = []
        for billboard, boxes in frames:
            covered = np.zeros(billboard.shape, bool)
            for x, y, w, h in boxes:
                x0, y0 = max(0, int(x - margin * w)), max(0, int(y - margin * h))
                x1, y1 = max(0, int(x + (1 + margin) * w)), max(0, int(y + (1 + margin) * h))
                covered[y0:y1, x0:x1] = True
            outside.append((billboard & ~covered).sum() / billboard.sum())
        print(f'margin {margin:g}: billboard pixels outside the boxes, median {np.median(outside):.3f}, '
              f'90th percentile {np.percentile(outside, 90):.3f}')


if __name__ == '__main__':
    main()
