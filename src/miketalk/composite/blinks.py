"""The blinks of a video registered to a model's reference: the frames whose eyes differ from
the usual (:func:`find_blinks`), measured on the eyes' band of the stabilized frames (0.8 to 1.4
mouth widths above the mouth box, :func:`eye_band`). Registration
(:func:`miketalk.composite.registration.register_video`) gives the bands as it stabilizes the
frames, a chunk at a time, to :class:`_EyeChanges`, which holds at most a block
(:data:`BLINK_BLOCK`) of them: memory does not grow with the video's length.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BLINK_BLOCK", "BLINK_FACTOR", "eye_band", "find_blinks"]

#: A frame blinks when its eye band differs from the sequence's median by this many
#: times the band's median difference (and at least 3 grey levels).
BLINK_FACTOR = 3.0


#: Bands measured at a time (in float): a bound on the memory of a measure.
_AT_ONCE = 50


def find_blinks(
    stabilized: np.ndarray, mouth_box: tuple[int, int, int, int], *, factor: float = BLINK_FACTOR
) -> tuple[int, ...]:
    """Frames whose eyes differ from the sequence's usual eyes: blinks.

    Parameters
    ----------
    stabilized : numpy.ndarray
        (N, H, W, 3) frames on the reference.
    mouth_box : tuple of int
        The mouth box: the eyes are 0.8 to 1.4 mouth widths above it (a face's
        proportions, as :mod:`miketalk.stabilize` uses them), across
        two mouth widths about its centre.
    factor : float
        See :data:`BLINK_FACTOR`.
    """
    return _blinks_of(eye_band(stabilized, mouth_box), factor=factor)


def eye_band(stabilized: np.ndarray, mouth_box: tuple[int, int, int, int]) -> np.ndarray:
    """``(N, h, w)`` float32 grey: the eyes' band of frames on the reference (0.8 to 1.4 mouth
    widths above the mouth box, two mouth widths about its centre)."""
    return stabilized[_eye_rows(mouth_box)].astype(np.float32).mean(axis=3)


def _eye_sums(stabilized: np.ndarray, mouth_box: tuple[int, int, int, int]) -> np.ndarray:
    """``(N, h, w)`` uint16: :func:`eye_band` times 3, exactly (the sum of each pixel's three
    channels, half the bytes of the band)."""
    return stabilized[_eye_rows(mouth_box)].sum(axis=3, dtype=np.uint16)


def _eye_rows(mouth_box: tuple[int, int, int, int]) -> tuple[slice, slice, slice]:
    """The index of :func:`eye_band`'s band in ``(N, H, W, 3)`` frames."""
    x, y, w, _ = mouth_box
    top, bottom = max(0, y - round(1.4 * w)), max(1, y - round(0.8 * w))
    left, right = max(0, round(x + w / 2 - 1.2 * w)), round(x + w / 2 + 1.2 * w)
    return slice(None), slice(top, bottom), slice(left, right)


def _blinks_of_sums(sums: np.ndarray, *, factor: float = BLINK_FACTOR) -> tuple[int, ...]:
    """:func:`_blinks_of` of the bands whose :func:`_eye_sums` are ``sums``, the same
    result, without the whole band in float (its median taken a few rows at a time)."""
    return _blinks_of_changes(_changes_of_sums(sums), factor=factor)


def _changes_of_sums(sums: np.ndarray) -> np.ndarray:
    """``(N,)`` each band's mean distance from the bands' median band (grey levels), of the
    bands whose :func:`_eye_sums` are ``sums``."""
    rows = max(1, (4 << 20) // (4 * sums.shape[0] * sums.shape[2]))  # about 4 MB in float
    median = np.concatenate(
        [np.median(sums[:, r : r + rows].astype(np.float32) / 3, axis=0)
         for r in range(0, sums.shape[1], rows)]
    )  # fmt: skip
    return np.concatenate(
        [np.abs(sums[i : i + _AT_ONCE].astype(np.float32) / 3 - median).mean(axis=(1, 2))
         for i in range(0, len(sums), _AT_ONCE)]
    )  # fmt: skip


def _blinks_of_changes(change: np.ndarray, *, factor: float = BLINK_FACTOR) -> tuple[int, ...]:
    """The frames whose eye change (:func:`_changes_of_sums`) is a blink's."""
    threshold = max(factor * float(np.median(change)), 3.0)
    return tuple(int(i) for i in np.flatnonzero(change > threshold))


#: Most frames whose eye bands are held at once: a longer video is cut into equal blocks of
#: at most this many frames, each measured against its own median band (its usual eyes), so
#: memory stops growing with the length (a minute at 25 fps: s1's crop's bands, 22 MB). Up
#: to this many frames, one block: the whole video's median, as before.
BLINK_BLOCK = 1500


class _EyeChanges:
    """Each frame's eye change (:func:`_changes_of_sums`) from the :func:`_eye_sums` of
    ``n`` frames given in order, a block (:data:`BLINK_BLOCK`) held at a time."""

    def __init__(self, n: int) -> None:
        blocks = max(1, -(-n // BLINK_BLOCK))
        self._ends = [round(n * (k + 1) / blocks) for k in range(blocks)]  # equal blocks
        self._held, self._done, self._count = [], [], 0  # bands held, changes, frames given
        self.most_held = 0  # frames' bands held at once, at most (a block)

    def add(self, sums: np.ndarray) -> None:
        """Take the next frames' :func:`_eye_sums`."""
        while len(sums):
            end = self._ends[len(self._done)] if len(self._done) < len(self._ends) else None
            take = len(sums) if end is None else min(len(sums), end - self._count)
            self._held.append(sums[:take])
            self._count += take
            self.most_held = max(self.most_held, sum(len(h) for h in self._held))
            sums = sums[take:]
            if end is not None and self._count == end:
                self._measure()

    def _measure(self) -> None:
        self._done += [_changes_of_sums(np.concatenate(self._held))] if self._held else []
        self._held = []

    def changes(self) -> np.ndarray:
        """``(n,)`` the frames' eye changes (those given, if fewer than ``n``)."""
        self._measure()
        return np.concatenate([np.zeros(0, np.float32), *self._done])


def _blinks_of(band: np.ndarray, *, factor: float = BLINK_FACTOR) -> tuple[int, ...]:
    """The frames whose eye band (:func:`eye_band`) differs from the usual (see
    :func:`find_blinks`)."""
    change = np.abs(band - np.median(band, axis=0)).mean(axis=(1, 2))
    return _blinks_of_changes(change, factor=factor)
