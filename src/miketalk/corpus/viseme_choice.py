"""Viseme images from continuous speech: candidates per phone, one image per class, fallbacks.

The paper (§4) takes each viseme from a word spoken alone, at "the point where
the mouth reaches its extremal position". In ordinary speech every phone of the
training clips is an instance of its viseme, and this module chooses among
them by two measured rules:

**Candidate of a phone.** Each nucleus of a phone (its middle; a diphthong's
two at a quarter and three quarters, as the lip-sync keyframes) gives one
frame: among the frames within a quarter of the phone's duration of the
nucleus (at least the nearest frame), the one where the mouth moves least,
``e_k = mean |I_{k+1} - I_{k-1}|`` over the mouth box. Where a trajectory turns
(its extremal position) its velocity is zero, so the stillest frame near the
middle is the extreme; a silence of at least :data:`MIN_SILENCE` seconds gives
its middle frame (the rest pose).

**Image of a class.** The medoid of the class's candidates in the mouth
region: the candidate whose mouth box (grey, half resolution) has the least
mean absolute difference to all the others. It is a real frame (no blending),
typical of the class, and it rejects what the middle of a phone often is in
connected speech: a blurred frame, or a pose pulled towards a neighbour by
coarticulation. :func:`choose_visemes` reports, per class, the medoid's mean
distance to its class against the mean over all candidates (how much the rule
gains over taking any instance) and its distance to the nearest other class's
image (whether the 16 images are distinct).

**One face around the mouths.** Each image is the chosen frame's lower face
(the box flows are estimated in, :func:`miketalk.mouth.flow_region`)
laid onto the corpus's reference frame with a feathered edge: the frames are
stabilized, so the two meet without a seam, and the rest of the face (eyes
that blink, brows) is the same in all 16 images, as it is in the paper's
recording of a subject told to keep still. The morph then moves only the mouth.

**Fallbacks.** A class with no candidate in the training clips takes the
image of the first class named for it in ``data/viseme_fallbacks.tsv`` that has
one (or, when none has, of the first that their own fallbacks reach), with a
warning; the table of visemes marks it, and the model's manifest
lists it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from miketalk.errors import MiketalkError
from miketalk.visemes import SILENCE, VisemeTable, read_table

log = logging.getLogger(__name__)

#: Shortest silence (seconds) whose middle frame is a candidate of the silence viseme.
MIN_SILENCE = 0.2

#: Fraction of a phone's duration searched on each side of a nucleus.
SEARCH_FRACTION = 0.25

_NUCLEI = {1: (0.5,), 2: (0.25, 0.75)}

#: The feathered edge of a viseme image's frame laid onto the reference (:func:`composite`),
#: in widths of the mouth region (:func:`miketalk.mouth.mouth_region`).
PASTE_FEATHER = 0.1


def read_fallbacks(path: str | Path | None = None) -> dict[str, tuple[str, ...]]:
    """``viseme -> fallbacks in order``, from ``data/viseme_fallbacks.tsv`` or ``path``."""
    rows = read_table(path, "viseme_fallbacks.tsv")
    return {row["viseme"]: tuple(row["fallbacks"].split(",")) for row in rows}


def mouth_energy(grey: np.ndarray, clip_starts: np.ndarray) -> np.ndarray:
    """``e_k = mean |I_{k+1} - I_{k-1}|`` per frame, one-sided at clip edges.

    Parameters
    ----------
    grey : (N, h, w) float32
        The mouth box of every frame.
    clip_starts : array of int
        First frame of every clip (frames of different clips are not neighbours).
    """
    n = len(grey)
    starts = np.asarray(clip_starts, int)
    ends = np.append(starts[1:], n) - 1
    clip_of = np.searchsorted(starts, np.arange(n), side="right") - 1
    prev = np.maximum(np.arange(n) - 1, starts[clip_of])
    nxt = np.minimum(np.arange(n) + 1, ends[clip_of])
    return np.abs(grey[nxt] - grey[prev]).mean(axis=(1, 2))


def phone_candidates(
    phones: pd.DataFrame, table: VisemeTable, *, energy: np.ndarray, fps: float
) -> pd.DataFrame:
    """One candidate frame per phone nucleus (and per long silence); see the module docstring.

    Parameters
    ----------
    phones : DataFrame
        ``phones.tsv`` of the corpus: ``clip``, ``phone``, ``start``, ``end``
        (recording time).
    table : VisemeTable
        Phone -> viseme(s).
    energy : (N,) array
        :func:`mouth_energy`.
    fps : float
        Frame rate.

    Returns
    -------
    DataFrame
        ``clip``, ``phone``, ``viseme``, ``nucleus`` (seconds), ``frame``.
    """
    n = len(energy)
    rows = []
    for row in phones.itertuples():
        start, end = float(row.start), float(row.end)
        duration = end - start
        visemes = table.visemes_of(row.phone)
        if visemes == (SILENCE,):
            if duration >= MIN_SILENCE:
                frame = min(n - 1, round((start + end) / 2 * fps))
                rows.append((row.clip, row.phone, SILENCE, (start + end) / 2, frame))
            continue
        for viseme, fraction in zip(visemes, _NUCLEI[len(visemes)], strict=True):
            t = start + fraction * duration
            reach = SEARCH_FRACTION * duration
            lo = max(0, int(np.ceil((t - reach) * fps)))
            hi = min(n - 1, int(np.floor((t + reach) * fps)))
            nearest = min(n - 1, max(0, round(t * fps)))
            window = np.arange(lo, hi + 1) if hi >= lo else np.array([nearest])
            order = np.lexsort((np.abs(window / fps - t), energy[window]))
            rows.append((row.clip, row.phone, viseme, t, int(window[order[0]])))
    return pd.DataFrame(rows, columns=["clip", "phone", "viseme", "nucleus", "frame"])


@dataclass(frozen=True)
class Choice:
    """The chosen image of one viseme class and how it was chosen."""

    viseme: str
    frame: int
    candidates: int
    medoid_distance: float
    mean_distance: float
    fallback: str | None = None


def medoid(features: np.ndarray) -> tuple[int, np.ndarray]:
    """Index of the medoid of ``features`` (N, d) under mean absolute difference, and the distances.

    Returns the medoid's index and the ``(N,)`` mean distance of every item to the others.
    """
    n = len(features)
    if n == 1:
        return 0, np.zeros(1)
    distance = np.zeros((n, n), np.float64)
    for i in range(n):  # N is a few hundred at most: one row of distances at a time
        distance[i] = np.abs(features - features[i]).mean(axis=1)
    mean = distance.sum(axis=1) / (n - 1)
    return int(np.argmin(mean)), mean


def mouth_features(grey_mouths: np.ndarray) -> np.ndarray:
    """Half-resolution grey mouth boxes, flattened: ``(N, d)`` float32 on a 0-1 scale."""
    small = [
        cv2.resize(m, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA).ravel()
        for m in grey_mouths
    ]
    return np.stack(small).astype(np.float32) / 255.0


def choose_visemes(
    candidates: pd.DataFrame,
    features: np.ndarray,
    table: VisemeTable,
    *,
    fallbacks: dict[str, tuple[str, ...]] | None = None,
) -> tuple[list[Choice], pd.DataFrame]:
    """The medoid of every class's candidates; fallbacks for classes without any.

    Parameters
    ----------
    candidates : DataFrame
        :func:`phone_candidates`.
    features : (N_frames, d) array
        :func:`mouth_features` of every frame of the recording (indexed by ``frame``).
    table : VisemeTable
        Its ``visemes`` are the classes.
    fallbacks : dict, optional
        ``viseme -> classes to borrow from, in order`` (default :func:`read_fallbacks`).

    Returns
    -------
    (list of Choice, DataFrame)
        One choice per class in the table's order, and the candidates with
        each one's mean distance to its class (``distance``) and whether it
        was chosen.

    Raises
    ------
    MiketalkError
        When a class has neither candidates nor a fallback that has.
    """
    fallbacks = read_fallbacks() if fallbacks is None else fallbacks
    candidates = candidates.copy()
    candidates["distance"] = np.nan
    candidates["chosen"] = False
    chosen: dict[str, Choice] = {}
    for viseme in table.visemes:
        rows = candidates.index[candidates["viseme"] == viseme]
        if len(rows) == 0:
            continue
        frames = candidates.loc[rows, "frame"].to_numpy(int)
        best, mean = medoid(features[frames])
        candidates.loc[rows, "distance"] = mean
        candidates.loc[rows[best], "chosen"] = True
        chosen[viseme] = Choice(
            viseme, int(frames[best]), len(rows), float(mean[best]), float(mean.mean())
        )
    out = []
    for viseme in table.visemes:
        if viseme in chosen:
            out.append(chosen[viseme])
            continue
        donor = _donor(viseme, fallbacks, chosen)
        if donor is None:
            raise MiketalkError(
                f"no instance of viseme {viseme!r} in the training clips, nor of any class "
                "data/viseme_fallbacks.tsv leads it to"
            )
        log.warning(
            "viseme %r has no instance in the training clips: it takes the image of %r",
            viseme,
            donor,
        )
        d = chosen[donor]
        out.append(Choice(viseme, d.frame, 0, d.medoid_distance, d.mean_distance, fallback=donor))
    return out, candidates


def _donor(viseme: str, fallbacks: dict[str, tuple[str, ...]], chosen: dict) -> str | None:
    """The nearest class with an image: the fallbacks in order, then theirs (breadth first)."""
    queue, seen = list(fallbacks.get(viseme, ())), {viseme}
    while queue:
        name = queue.pop(0)
        if name in seen:
            continue
        if name in chosen:
            return name
        seen.add(name)
        queue += fallbacks.get(name, ())
    return None


def paste_weight(
    shape: tuple[int, int], box: tuple[int, int, int, int], *, feather: float
) -> np.ndarray:
    """``(H, W)`` float32: how much of :func:`composite`'s image is the frame's (1 inside
    ``box``, 0 outside, over a Gaussian edge of ``feather`` px)."""
    x, y, w, h = box
    weight = np.zeros(shape, np.float32)
    inset = round(feather)
    weight[y + inset : y + h - inset, x + inset : x + w - inset] = 1.0
    return cv2.GaussianBlur(weight, (0, 0), max(feather / 2, 0.5))


def composite(
    frame: np.ndarray, reference: np.ndarray, box: tuple[int, int, int, int], *, feather: float
) -> np.ndarray:
    """``frame`` inside ``box``, ``reference`` outside, over a Gaussian edge of ``feather`` px."""
    weight = paste_weight(frame.shape[:2], box, feather=feather)[..., None]
    out = weight * frame.astype(np.float32) + (1 - weight) * reference.astype(np.float32)
    return np.clip(out + 0.5, 0, 255).astype(np.uint8)


def separation(choices: list[Choice], features: np.ndarray) -> dict[str, float]:
    """Distance from each class's image to the nearest other class's image (0: a fallback)."""
    frames = np.array([c.frame for c in choices])
    f = features[frames]
    out = {}
    for i, c in enumerate(choices):
        others = [j for j in range(len(choices)) if j != i]
        out[c.viseme] = float(min(np.abs(f[others] - f[i]).mean(axis=1))) if others else 0.0
    return out


def choose_visemes_stage(*, corpus_dir: Path, grouping: dict, out: object) -> list[Choice]:
    """The ``visemes`` rule for a corpus of clips: candidates, the 16 images, the contact sheet.

    ``out`` has the rule's named outputs: ``targets`` (every candidate, its
    class distance and whether it was chosen), ``visemes`` (the table the flows
    and the model read: ``viseme``, ``frame``, ``image``, with ``clip``,
    ``clip_frame``, ``phone``, ``candidates``, the distances and ``fallback``),
    ``images`` and ``sheet``.
    """

    from miketalk.corpus.clips import CLIPS_TABLE, PHONES_TABLE, REFERENCE
    from miketalk.corpus.folder import FRAMES_TABLE, open_corpus
    from miketalk.media.atomic import write_text_atomic
    from miketalk.media.images import read_image, write_png
    from miketalk.media.sheets import grid
    from miketalk.mouth import flow_region, mouth_region
    from miketalk.visemes import viseme_slug

    corpus_dir = Path(corpus_dir)
    table = VisemeTable(grouping=grouping)
    video = open_corpus(corpus_dir)
    x, y, w, h = mouth_region(corpus_dir)
    mouths = np.stack(
        [
            cv2.cvtColor(
                np.ascontiguousarray(video.frame(k)[y : y + h, x : x + w]), cv2.COLOR_RGB2GRAY
            )
            for k in range(video.n_frames)
        ]
    )
    clips = pd.read_csv(corpus_dir / CLIPS_TABLE, sep="\t", dtype={"clip": str})
    phones = pd.read_csv(corpus_dir / PHONES_TABLE, sep="\t", dtype={"clip": str})
    energy = mouth_energy(mouths.astype(np.float32), clips["first_frame"].to_numpy())
    candidates = phone_candidates(phones, table, energy=energy, fps=video.fps)
    features = mouth_features(mouths)
    choices, scored = choose_visemes(candidates, features, table)
    apart = separation(choices, features)
    frames = pd.read_csv(corpus_dir / FRAMES_TABLE, sep="\t", dtype={"clip": str})
    write_text_atomic(out.targets, scored.to_csv(sep="\t", index=False, float_format="%.5f"))

    reference = read_image(corpus_dir / REFERENCE)
    region = flow_region(corpus_dir)
    images_dir = Path(out.images)
    images_dir.mkdir(parents=True, exist_ok=True)
    rows, images, labels = [], [], []
    for c in choices:
        image = composite(video.frame(c.frame), reference, region, feather=PASTE_FEATHER * w)
        name = f"{viseme_slug(c.viseme)}.png"
        write_png(images_dir / name, image)
        where = frames.iloc[c.frame]
        phone = scored[(scored["frame"] == c.frame) & scored["chosen"]]["phone"]
        phone = phone.iloc[0] if len(phone) else ""
        rows.append(
            {
                "viseme": c.viseme, "frame": c.frame, "image": name, "clip": where["clip"],
                "clip_frame": int(where["clip_frame"]), "phone": phone,
                "candidates": c.candidates, "medoid_distance": c.medoid_distance,
                "mean_distance": c.mean_distance, "separation": apart[c.viseme],
                "fallback": c.fallback or "",
            }
        )  # fmt: skip
        cx, cy = x + w // 2, y + h // 2
        half_w, half_h = int(1.3 * w), int(w)
        crop = image[max(0, cy - half_h) : cy + half_h, max(0, cx - half_w) : cx + half_w]
        images.append(np.ascontiguousarray(crop))
        source = f"= {c.fallback}" if c.fallback else f"{phone} n={c.candidates}"
        labels.append(f"{c.viseme}: {where['clip']} f{int(where['clip_frame'])} {source}")
    write_text_atomic(
        out.visemes, pd.DataFrame(rows).to_csv(sep="\t", index=False, float_format="%.5f")
    )
    write_png(out.sheet, grid(images, labels, cols=4, scale=200 / images[0].shape[1]))
    return choices
