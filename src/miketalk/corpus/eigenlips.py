"""A corpus's eigenlips fitted once and kept in a file.

The eigenlips of a face built from clips (:class:`miketalk.mouth.Eigenlips`,
the principal components of its training frames' grey mouth regions) are used
twice: to fit the face's learned coarticulation on the training clips'
trajectories (:func:`miketalk.draw.coarticulation.fit_coarticulation`) and to
compare held-out clips with their re-synthesis
(:func:`miketalk_lab.evaluation.heldout.heldout_stage`). Reading every corpus
frame and decomposing the (frames x pixels) matrix is most of what either
costs, so the workflow does it once (rule ``eigenlips``) and both read this
file: the same arrays, so the same results as fitting them in each.

The file is an ``.npz`` of ``mean``, ``components``, ``variance``,
``explained`` (the fit) and ``coordinates``: every training frame's
coefficients, ``(N, n)``.
"""

from __future__ import annotations

import io
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from miketalk.media.atomic import write_bytes_atomic
from miketalk.mouth.eigenlips import N_EIGENLIPS, Eigenlips
from miketalk.mouth.region import grey_mouths, mouth_region


@dataclass(frozen=True)
class CorpusEigenlips:
    """A corpus's eigenlips and the coefficients of its frames.

    Attributes
    ----------
    eigenlips : Eigenlips
        Fitted on the grey mouth regions of every corpus frame.
    coordinates : (N, n) float64
        Each corpus frame's coefficients (``eigenlips.project`` of its mouth).
    """

    eigenlips: Eigenlips
    coordinates: np.ndarray


def corpus_mouths(corpus_dir: str | os.PathLike[str]) -> np.ndarray:
    """The grey mouth region (:func:`miketalk.mouth.mouth_region`) of every corpus frame,
    ``(N, h, w)`` float32."""
    from miketalk.corpus.folder import count_frames, frame_path
    from miketalk.media.images import read_image

    box = mouth_region(corpus_dir)
    frames_dir = Path(corpus_dir) / "frames"
    mouths = np.empty((count_frames(frames_dir), box[3], box[2]), np.float32)
    for k in range(len(mouths)):  # filled in place: a long corpus's mouths are held once
        mouths[k] = grey_mouths(read_image(frame_path(frames_dir, k))[None], box)[0]
    return mouths


def fit_corpus_eigenlips(
    corpus_dir: str | os.PathLike[str], *, n: int = N_EIGENLIPS
) -> CorpusEigenlips:
    """Fit the eigenlips of a corpus folder's frames and project every frame on them."""
    mouths = corpus_mouths(corpus_dir)
    eigenlips = Eigenlips(mouths, n=n)
    return CorpusEigenlips(eigenlips, eigenlips.project(mouths))


def write_eigenlips(path: str | os.PathLike[str], fitted: CorpusEigenlips) -> None:
    """Write ``fitted`` to ``path`` (``.npz``, atomically)."""
    e = fitted.eigenlips
    buf = io.BytesIO()
    np.savez(
        buf, mean=e.mean, components=e.components, variance=e.variance,
        explained=e.explained, coordinates=fitted.coordinates,
    )  # fmt: skip
    write_bytes_atomic(path, buf.getvalue())


def read_eigenlips(path: str | os.PathLike[str]) -> CorpusEigenlips:
    """The eigenlips :func:`write_eigenlips` wrote."""
    with np.load(path) as data:
        eigenlips = Eigenlips.restore(
            mean=data["mean"], components=data["components"],
            variance=data["variance"], explained=data["explained"],
        )  # fmt: skip
        return CorpusEigenlips(eigenlips, data["coordinates"])
