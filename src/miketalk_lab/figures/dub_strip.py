"""Strips of a composited video: every ``step``-th frame, whole and cropped to the mouth.

``python -m miketalk_lab.figures.dub_strip VIDEO.mp4 --out strip.png [--split 2] [--step 5]
[--mouth X Y W H]``: a video of ``split`` side-by-side columns (real | dubbed)
becomes one row per column, each tile labelled with its frame number; the mouth
rows crop ``--mouth`` (in one column's pixels), enlarged to a tile's width.
"""

from __future__ import annotations

import argparse

import cv2
import numpy as np


def strip(
    frames: np.ndarray, *, split: int = 1, step: int = 5, mouth=None, scale: float = 0.5
) -> np.ndarray:
    """One image: per column of the video a row of whole frames, then a row of mouth crops.

    Parameters
    ----------
    frames : numpy.ndarray
        (N, H, W, 3) uint8.
    split : int
        Side-by-side columns in each frame.
    step : int
        Every ``step``-th frame.
    mouth : tuple of int, optional
        ``(x, y, w, h)`` crop inside one column (enlarged to a tile's width).
    scale : float
        Size of the whole-frame tiles.
    """
    picks = list(range(0, len(frames), step))
    width = frames.shape[2] // split
    rows = []
    for c in range(split):
        columns = frames[:, :, c * width : (c + 1) * width]
        tiles = []
        for k in picks:
            tile = cv2.resize(columns[k], None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
            cv2.putText(tile, str(k), (3, 12), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 0), 1)
            tiles.append(tile)
        rows.append(np.concatenate(tiles, axis=1))
        if mouth is not None:
            x, y, w, h = mouth
            zoom = tiles[0].shape[1] / w  # a crop as wide as a whole-frame tile
            crops = [
                cv2.resize(columns[k, y : y + h, x : x + w], None, fx=zoom, fy=zoom,
                           interpolation=cv2.INTER_CUBIC)
                for k in picks
            ]  # fmt: skip
            row = np.concatenate(crops, axis=1)
            pad = rows[-1].shape[1] - row.shape[1]
            if pad > 0:
                row = np.pad(row, ((0, 0), (0, pad), (0, 0)))
            rows.append(row[:, : rows[-1].shape[1]])
    return np.concatenate(rows, axis=0)


def main(argv: list[str] | None = None) -> int:
    """Command line (see the module docstring)."""
    from miketalk.media.decode import read_video
    from miketalk.media.images import write_png

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("video")
    parser.add_argument("--out", required=True)
    parser.add_argument("--split", type=int, default=1)
    parser.add_argument("--step", type=int, default=5)
    parser.add_argument("--first", type=int, default=0, help="first frame")
    parser.add_argument("--count", type=int, default=None, help="frames from the first")
    parser.add_argument("--mouth", type=int, nargs=4, default=None)
    parser.add_argument("--scale", type=float, default=0.5)
    args = parser.parse_args(argv)
    frames, _ = read_video(args.video)
    end = None if args.count is None else args.first + args.count
    frames = frames[args.first : end]
    write_png(
        args.out,
        strip(frames, split=args.split, step=args.step, mouth=args.mouth, scale=args.scale),
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
