"""Every training frame measured: its mouth description and the patch it is drawn with.

A face built from clips has all its training frames stabilized onto one
reference (:mod:`miketalk.corpus.clips`). For each frame this module keeps

the description
    the frame's grey mouth region (:func:`miketalk.mouth.mouth_region`),
    normalized to zero mean and unit variance (what differs between recording
    sessions, exposure and white balance, is not a mouth shape), projected on
    the first ``components`` principal components of all training frames'
    regions: the held-out evaluation's eigenlips (Bregler & Konig 1994), more
    of them;
the patch
    the colour region about the mouth that is composited onto the face when
    the frame is drawn (:func:`patch_box`: lips, teeth, tongue, cheeks and the
    chin, which follows the jaw), and the mean colour of its border band, so
    that a patch from another session can be brought to the face's light.

:func:`measure_frames` measures a corpus folder; :class:`MouthFrames` holds the
result and :meth:`MouthFrames.save` / :func:`load_frames` keep it in a model
directory (``patches.npy``, read memory-mapped: only the frames drawn are read).
"""

from __future__ import annotations

import json
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from miketalk.errors import MiketalkError
from miketalk.mouth.eigenlips import normalized

Box = tuple[int, int, int, int]

#: The patch about the mouth box's centre, in mouth widths: each side, above, below.
PATCH_EXTENT = (1.15, 0.75, 1.2)

#: Pixels from the patch's edge to where the feathered mask is half opaque, and its blur.
FEATHER_INSET, FEATHER_SIGMA = 11, 3.5

PATCHES, DESCRIPTION, FRAMES_JSON = "patches.npy", "description.npz", "frames.json"


def patch_box(mouth_box: Box, size: tuple[int, int], extent: tuple[float, float, float]) -> Box:
    """The patch ``(x, y, w, h)`` about ``mouth_box``'s centre, clipped to a frame of ``size``.

    ``extent`` is (side, above, below) in mouth widths; ``size`` is (H, W).
    """
    x, y, w, h = mouth_box
    side, above, below = extent
    cx, cy = x + w / 2, y + h / 2
    x0, x1 = max(0, round(cx - side * w)), min(size[1], round(cx + side * w))
    y0, y1 = max(0, round(cy - above * w)), min(size[0], round(cy + below * w))
    return x0, y0, x1 - x0, y1 - y0


def feather_mask(
    height: int, width: int, *, inset: int = FEATHER_INSET, sigma: float = FEATHER_SIGMA
) -> np.ndarray:
    """``(height, width)`` float32 weights: 1 inside, falling smoothly to ~0 at the border.

    A rectangle ``inset`` pixels inside the patch, blurred by a Gaussian of
    ``sigma`` pixels; the border row and column are then 0 to 1e-3.
    """
    if min(height, width) <= 2 * inset:
        raise MiketalkError(f"a {width}x{height} patch is too small for a {inset} px feather")
    mask = np.zeros((height, width), np.float32)
    mask[inset : height - inset, inset : width - inset] = 1.0
    return cv2.GaussianBlur(mask, (0, 0), sigma, borderType=cv2.BORDER_CONSTANT)


def grey(frames: np.ndarray) -> np.ndarray:
    """BT.601 luma of ``(..., 3)`` uint8 frames, float32."""
    return np.asarray(frames, np.float32) @ np.array([0.299, 0.587, 0.114], np.float32)


def principal_axes(
    centred: np.ndarray, count: int, *, oversample: int = 12, iterations: int = 4
) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` largest singular values and right singular vectors of ``centred``.

    A randomized range finder (Halko, Martinsson & Tropp 2011) with a fixed
    seed and ``iterations`` power iterations: the leading axes to many digits
    in a few matrix products, where a full SVD of 3000 frames by 3000 pixels
    takes a minute. Deterministic.
    """
    rng = np.random.default_rng(0)
    probe = rng.standard_normal((centred.shape[1], min(count + oversample, min(centred.shape))))
    basis, _ = np.linalg.qr(centred @ probe)
    for _ in range(iterations):
        basis, _ = np.linalg.qr(centred.T @ basis)
        basis, _ = np.linalg.qr(centred @ basis)
    _, s, vt = np.linalg.svd(basis.T @ centred, full_matrices=False)
    return s[:count], vt[:count]


@dataclass(frozen=True)
class MouthFrames:
    """Every training frame's description and patch (see the module docstring).

    Attributes
    ----------
    coords : (N, n) float64
        Each frame's description (principal component coefficients).
    patches : (N, ph, pw, 3) uint8
        Each frame's colour patch (may be memory-mapped).
    border : (N, 3) float32
        The mean colour of each patch's border band (where the mask is partial).
    clip : (N,) int
        Each frame's clip (index into ``clip_ids``).
    clip_frame : (N,) int
        Each frame's index in its clip.
    clip_ids : tuple of str
    mean, components : arrays
        The principal components: ``coords = (normalized(region) - mean) @ components.T``.
    variance : (n,) float64
        Each component's variance over the training frames.
    region, patch : (x, y, w, h)
        The measured mouth region and the patch, in frame coordinates.
    fps : float
        The recording's frame rate.
    """

    coords: np.ndarray
    patches: np.ndarray
    border: np.ndarray
    clip: np.ndarray
    clip_frame: np.ndarray
    clip_ids: tuple[str, ...]
    mean: np.ndarray
    components: np.ndarray
    variance: np.ndarray
    region: Box
    patch: Box
    fps: float

    def project(self, regions: np.ndarray) -> np.ndarray:
        """Descriptions ``(N, n)`` of grey mouth regions ``(N, h, w)``."""
        return (normalized(regions) - self.mean) @ self.components.T

    def continues(self) -> np.ndarray:
        """``(N,)`` bool: frame ``i + 1`` follows frame ``i`` in the same clip."""
        same = np.zeros(len(self.clip), bool)
        same[:-1] = (self.clip[1:] == self.clip[:-1]) & (
            self.clip_frame[1:] == self.clip_frame[:-1] + 1
        )
        return same

    def save(self, directory: str | os.PathLike[str]) -> None:
        """Write ``patches.npy``, ``description.npz`` and ``frames.json`` into ``directory``."""
        from miketalk.media.atomic import atomic_path, write_text_atomic

        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        with atomic_path(out / PATCHES) as tmp, open(tmp, "wb") as f:
            np.save(f, np.ascontiguousarray(self.patches, np.uint8), allow_pickle=False)
        with atomic_path(out / DESCRIPTION) as tmp, open(tmp, "wb") as f:
            np.savez(
                f, coords=self.coords, border=self.border, clip=self.clip,
                clip_frame=self.clip_frame, mean=self.mean, components=self.components,
                variance=self.variance,
            )  # fmt: skip
        doc = {
            "clip_ids": list(self.clip_ids),
            "region": list(self.region),
            "patch": list(self.patch),
            "fps": self.fps,
        }
        write_text_atomic(out / FRAMES_JSON, json.dumps(doc, indent=1))


def load_frames(directory: str | os.PathLike[str]) -> MouthFrames:
    """The :class:`MouthFrames` :meth:`MouthFrames.save` wrote (patches memory-mapped).

    Raises
    ------
    MiketalkError
        When a file is missing or unreadable.
    """
    d = Path(directory)
    try:
        doc = json.loads((d / FRAMES_JSON).read_text(encoding="utf-8"))
        with np.load(d / DESCRIPTION, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        patches = np.load(d / PATCHES, mmap_mode="r", allow_pickle=False)
    except (OSError, ValueError, KeyError) as err:
        raise MiketalkError(f"cannot read the trained face's frames in {d}: {err}") from None
    return MouthFrames(
        coords=arrays["coords"], patches=patches, border=arrays["border"],
        clip=arrays["clip"], clip_frame=arrays["clip_frame"],
        clip_ids=tuple(doc["clip_ids"]), mean=arrays["mean"],
        components=arrays["components"], variance=arrays["variance"],
        region=tuple(doc["region"]), patch=tuple(doc["patch"]), fps=float(doc["fps"]),
    )  # fmt: skip


def measure_frames(
    corpus_dir: str | os.PathLike[str],
    *,
    components: int = 16,
    extent: tuple[float, float, float] = PATCH_EXTENT,
    workers: int = 2,
) -> MouthFrames:
    """Measure every frame of a corpus folder built from clips (see the module docstring).

    Parameters
    ----------
    corpus_dir : path
        The face's corpus folder (its training clips: ``frames/``, ``clips.tsv``,
        ``regions.json``).
    components : int
        Principal components kept as the description.
    extent : (side, above, below)
        The patch, in mouth widths about the mouth box's centre.
    workers : int
        Threads reading frames.
    """
    import pandas as pd

    from miketalk.corpus.folder import count_frames, frame_path, open_corpus
    from miketalk.media.images import read_image
    from miketalk.mouth import mouth_box, mouth_region

    corpus_dir = Path(corpus_dir)
    fps = float(open_corpus(corpus_dir).fps)
    regions = json.loads((corpus_dir / "regions.json").read_text(encoding="utf-8"))
    size = tuple(int(v) for v in regions["size"])
    region = mouth_region(corpus_dir)
    patch = patch_box(mouth_box(corpus_dir), size, extent)
    px, py, pw, ph = patch
    rx, ry, rw, rh = region
    if not (px <= rx and py <= ry and rx + rw <= px + pw and ry + rh <= py + ph):
        raise MiketalkError(f"the patch {patch} does not hold the mouth region {region}")
    frames_dir = corpus_dir / "frames"
    n = count_frames(frames_dir)
    patches = np.empty((n, ph, pw, 3), np.uint8)

    def read(k: int) -> None:
        patches[k] = read_image(frame_path(frames_dir, k))[py : py + ph, px : px + pw]

    with ThreadPoolExecutor(max(1, workers)) as pool:
        list(pool.map(read, range(n)))
    coords, mean, comps, variance = describe(patches, patch=patch, region=region,
                                             components=components)  # fmt: skip
    mask = feather_mask(ph, pw)
    band = (mask > 0.02) & (mask < 0.98)
    border = patches[:, band].astype(np.float32).mean(axis=1)
    clips = pd.read_csv(corpus_dir / "clips.tsv", sep="\t", dtype={"clip": str})
    clip = np.full(n, -1, np.int64)
    clip_frame = np.zeros(n, np.int64)
    for i, row in enumerate(clips.itertuples(index=False)):
        first, count = int(row.first_frame), int(row.frames)
        clip[first : first + count] = i
        clip_frame[first : first + count] = np.arange(count)
    if (clip < 0).any():
        raise MiketalkError(f"{corpus_dir}: frames outside every clip of clips.tsv")
    return MouthFrames(
        coords=coords, patches=patches, border=border, clip=clip, clip_frame=clip_frame,
        clip_ids=tuple(str(c) for c in clips["clip"]), mean=mean, components=comps,
        variance=variance, region=region, patch=patch, fps=fps,
    )  # fmt: skip


def describe(
    patches: np.ndarray, *, patch: Box, region: Box, components: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The principal components of the mouth regions of ``patches`` (N, ph, pw, 3) uint8.

    Each frame's grey mouth region (``region``, inside ``patch``) normalized
    (:func:`~miketalk.mouth.eigenlips.normalized`), centred, and its ``components`` largest
    principal axes, each pointing the way the mouth darkens (the eigenlips' sign).

    Returns
    -------
    coords, mean, components, variance : numpy.ndarray
        ``(N, n)`` each frame's description, the mean row, ``(n, h*w)`` the axes and
        ``(n,)`` the variance along each.
    """
    px, py, _, _ = patch
    rx, ry, rw, rh = region
    data = normalized(grey(patches[:, ry - py : ry - py + rh, rx - px : rx - px + rw]))
    if len(data) <= components:
        raise MiketalkError(f"{components} components need more frames than {len(data)}")
    mean = data.mean(axis=0)
    data -= mean  # centred in place: a long corpus's frames are held once
    s, comps = principal_axes(data, components)
    darker = -np.sign(comps.sum(axis=1))
    comps = comps * np.where(darker == 0, 1.0, darker)[:, None]
    return data @ comps.T, mean, comps, (s[:components] ** 2) / (len(data) - 1)
