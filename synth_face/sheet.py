"""A labelled contact sheet of the corpus targets, for looking at the face.

Usage: ``python -m synth_face.sheet OUT.png [SIZE]``.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from miketalk.media.atomic import atomic_path
from miketalk.media.sheets import grid
from synth_face.face import Face
from synth_face.render import FaceRenderer


def target_sheet(
    renderer: FaceRenderer,
    keys: Sequence[str] | None = None,
    *,
    cols: int = 8,
    crop: bool = True,
) -> np.ndarray:
    """Render targets side by side, each labelled with its key and viseme (:func:`grid`).

    Parameters
    ----------
    renderer : FaceRenderer
        The renderer (its face supplies the targets).
    keys : sequence of str, optional
        Target keys; all corpus targets in table order by default.
    cols : int
        Tiles per row.
    crop : bool
        Keep only the mouth's neighbourhood (the middle of the frame).

    Returns
    -------
    ndarray, shape (h, w, 3) uint8
        The sheet (RGB).
    """
    face = renderer.face
    viseme = {t.key: t.viseme for t in face.table.targets}
    keys = list(face.target_keys if keys is None else keys)
    n = renderer.size
    tiles = []
    for key in keys:
        img = renderer.render(face.target(key))
        if crop:
            img = img[int(0.22 * n) : int(0.78 * n), int(0.15 * n) : int(0.85 * n)]
        tiles.append(img)
    return grid(tiles, [f"{key} /{viseme.get(key, '?')}/" for key in keys], cols=cols)


def main(argv: list[str] | None = None) -> None:
    """Write the contact sheet of all corpus targets to a PNG."""
    args = sys.argv[1:] if argv is None else argv
    if not args:
        raise SystemExit("usage: python -m synth_face.sheet OUT.png [SIZE]")
    size = int(args[1]) if len(args) > 1 else 256
    with FaceRenderer(Face(), size) as r:
        sheet = target_sheet(r)
    out = Path(args[0])
    with atomic_path(out) as tmp:
        cv2.imwrite(str(tmp), sheet[..., ::-1])


if __name__ == "__main__":
    main()
