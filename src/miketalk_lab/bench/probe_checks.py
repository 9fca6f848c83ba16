"""What a bad-input run left: its stderr lines, its files, the frames a dub left untouched.

The checks of :mod:`miketalk_lab.bench.bad_input`, each on the files a ``miketalk`` run
left behind: :func:`stderr_lines` (its ``miketalk:`` lines; a traceback), :func:`leftovers`
(the files in its folder besides the output), :func:`named_frames` (the frames a dub's
warning names), :func:`dub_frames` (per frame, whether the dub changed it), and
:func:`strip` (a picture of a few frames: the probe above, the dub below).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from pathlib import Path

import cv2
import numpy as np

__all__ = [
    "CHANGED_LEVELS",
    "CHANGED_PIXELS",
    "changed_pixels",
    "dub_frames",
    "leftovers",
    "named_frames",
    "ranges",
    "skipped_rows",
    "stderr_lines",
    "strip",
]

#: A pixel is changed by a dub when its grey level (both frames blurred by 5x5) moved by
#: more than this, and it lies in a blob that an opening by a 9-pixel disc keeps: H.264's
#: second round trip (x264 crf 18) moves scattered pixels, along sharp edges (a pasted
#: face's), that the opening removes. Over the four addresses' dubs to their own sound
#: (a mouth much like the one it replaces), every frame a dub changed kept 555 or more
#: pixels, every frame it left alone none.
CHANGED_LEVELS = 4
#: A frame is changed by a dub when more pixels than this are.
CHANGED_PIXELS = 100
_OPENING = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (9, 9))
_FRAMES = re.compile(r"\bframes? (\d+)(?:-(\d+))?:")
_NAMING = "play without a new mouth"


def stderr_lines(stderr: str) -> tuple[list[str], bool]:
    """The ``miketalk:`` lines of a run's stderr (warnings, the error), and whether it holds a
    traceback (its last line is then added)."""
    lines = [ln.strip() for ln in stderr.splitlines() if ln.startswith("miketalk: ")]
    traceback = "Traceback (most recent call last)" in stderr
    if traceback:
        lines.append(stderr.strip().splitlines()[-1])
    return lines, traceback


def leftovers(folder: Path, expected: Iterable[str]) -> tuple[list[str], list[str]]:
    """The outputs ``expected`` found in a run's ``folder``, and everything else in it or in its
    ``tmp`` (its ``TMPDIR``) but ``stderr.txt``: what the run left over."""
    expected = set(expected)
    names = sorted(p.name for p in folder.iterdir() if p.name not in ("stderr.txt", "tmp"))
    temp = sorted(f"tmp/{p.name}" for p in (folder / "tmp").iterdir()) if (
        folder / "tmp").is_dir() else []  # fmt: skip
    return [n for n in names if n in expected], [n for n in names if n not in expected] + temp


def named_frames(lines: Sequence[str]) -> set[int]:
    """The frames a dub's warning names as playing without a new mouth (``frames 20-64: ...``;
    a list ending in ``...`` names only its first ranges)."""
    named: set[int] = set()
    for line in lines:
        if _NAMING not in line:
            continue
        for first, last in _FRAMES.findall(line):
            named.update(range(int(first), int(last or first) + 1))
    return named


def ranges(frames: Iterable[int]) -> str:
    """``0-4, 7, 9-10``: sorted frame numbers as runs (empty: none)."""
    out: list[str] = []
    values = sorted(set(frames))
    start = prev = None
    for k in [*values, None]:
        if k is not None and prev is not None and k == prev + 1:
            prev = k
            continue
        if start is not None:
            out.append(f"{start}" if start == prev else f"{start}-{prev}")
        start = prev = k
    return ", ".join(out)


def skipped_rows(model: Path) -> list[str]:
    """``clip: reason`` of a built model's ``build/skipped.tsv`` (none if absent)."""
    table = model / "build" / "skipped.tsv"
    if not table.is_file():
        return []
    rows = [ln.split("\t") for ln in table.read_text("utf-8").splitlines()[1:] if ln.strip()]
    return [": ".join(r) for r in rows]


def changed_pixels(before: np.ndarray, after: np.ndarray) -> int:
    """How many pixels of two grey frames differ by more than :data:`CHANGED_LEVELS` (5x5
    blurred), in blobs (opened by a 9-pixel disc)."""
    a = cv2.blur(before.astype(np.int16), (5, 5))
    b = cv2.blur(after.astype(np.int16), (5, 5))
    moved = (np.abs(a - b) > CHANGED_LEVELS).astype(np.uint8)
    return int(cv2.morphologyEx(moved, cv2.MORPH_OPEN, _OPENING).sum())


def dub_frames(video: Path, dub: Path) -> list[dict]:
    """Per frame of the probe ``video`` the dub played over it: ``changed_px`` and ``changed``
    (:func:`changed_pixels` above :data:`CHANGED_PIXELS`), compared frame ``k`` to frame ``k``
    (a dub to the video's own sound plays it once, forwards)."""
    from miketalk.media.decode import iter_video_frames

    out = []
    for before, after in zip(iter_video_frames(video, grey=True),
                             iter_video_frames(dub, grey=True), strict=False):  # fmt: skip
        px = changed_pixels(before, after) if before.shape == after.shape else before.size
        out.append({"changed_px": px, "changed": int(px > CHANGED_PIXELS)})
    return out


def _picks(n: int, changed: Sequence[int], named: set[int]) -> list[int]:
    """Up to 8 frames to show: around and inside what the probe changed, and named ones."""
    if not changed or len(changed) >= n:
        picks = set(np.linspace(0, n - 1, 6).round().astype(int).tolist())
    elif len(changed) < 5:  # cuts: the frames either side of each
        picks = {c + d for c in changed for d in (-1, 0)}
    else:
        c = sorted(changed)
        picks = {c[0] - 4, c[0] + 2, c[len(c) // 2], c[-1] - 2, c[-1] + 4}
    if named:
        picks |= {min(named), max(named)}
    return sorted(k for k in picks if 0 <= k < n)[:8]


def strip(
    video: Path, dub: Path, path: Path, changed: Sequence[int], named: set[int],
    frames: Sequence[dict], geometry: np.ndarray, *, height: int = 240, half_width: float = 3.5,
) -> None:  # fmt: skip
    """Write ``path``: a few frames around the face (``2 * half_width`` by 6 eye distances
    about where the source's face is, ``geometry`` of
    :func:`miketalk_lab.probe_videos.face_geometry`), the
    probe's above the dub's, labelled with the frame's number and whether the probe changed
    it, the warning names it, and the dub changed it."""
    from miketalk.media.decode import iter_video_frames
    from miketalk.media.images import write_png

    picks = _picks(len(frames), changed, named)
    cells: dict[int, list[np.ndarray]] = {k: [] for k in picks}
    for source in (video, dub):
        for k, frame in enumerate(iter_video_frames(source)):
            if k in cells:
                x, y, d = geometry[k]
                top, left = max(0, round(y - 2 * d)), max(0, round(x - half_width * d))
                box = frame[top : round(y + 4 * d), left : round(x + half_width * d)]
                width = round(box.shape[1] * height / box.shape[0])
                cells[k].append(cv2.resize(box, (width, height), interpolation=cv2.INTER_AREA))
            if k > max(picks):
                break
    columns = []
    for k in picks:
        top, bottom = cells[k]
        marks = [f"{k}", "probe" if k in set(changed) else "", "named" if k in named else "",
                 "dubbed" if frames[k]["changed"] else "untouched"]  # fmt: skip
        label = " ".join(m for m in marks if m)
        for cell in (top, bottom):
            cv2.putText(cell, label, (4, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 0), 1)
        columns.append(np.concatenate([top, bottom], axis=0))
        columns.append(np.zeros((2 * height, 4, 3), np.uint8))
    write_png(path, np.concatenate(columns[:-1], axis=1))
