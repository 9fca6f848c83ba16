"""The config's sweeps (``sweeps``): the faces, flow methods and lip-sync settings they add.

- training clips: the same face from N training clips, for each N
  (:func:`training_sweep_faces`);
- pyramid depth: flow methods ``<estimator>-L<levels>`` (:func:`sweep_methods`);
- sync: the sweep sentence in each sampling mode, at each max_px_per_frame and fps, one
  setting at a time (:func:`sync_sweep_points`), always with the paper's lip-sync model.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

from miketalk import defaults
from miketalk.corpus.clip_sources import read_transcripts
from miketalk_lab.workflow import faces
from miketalk_lab.workflow.config import ConfigError, canonical
from miketalk_lab.workflow.vocabulary import PAPER

#: A sweep point: (sampling, max_px_per_frame, fps).
Point = tuple[str, float, float]


def sweep_face(face: str, n: int) -> str:
    """The name of ``face`` built from ``n`` training clips: ``<face>-n<n>``."""
    return f"{face}-n{n}"


def training_sweep_faces(
    configured: Mapping[str, Mapping], counts: Sequence[int], root: Path
) -> dict[str, dict]:
    """For each face from clips: the same face from N training clips, for each N in ``counts``.

    Named ``<face>-n<N>``; they share the face's test clips. A face without test clips, or
    an N equal to its own number of training clips, adds none.

    Parameters
    ----------
    configured : Mapping
        The config's faces (their defaults filled in).
    counts : sequence of int
        ``sweeps.training_clips``.
    root : Path
        The project directory (relative transcript tables are in it).

    Returns
    -------
    dict
        The sweep's faces' settings by name: the face's, its ``corpus.train`` replaced
        (:func:`sweep_training_clips`).
    """
    out = {}
    for face, settings in configured.items():
        corpus = settings["corpus"]
        if corpus["source"] != faces.CLIPS or not corpus["test"]:
            continue
        for n in counts:
            if n != len(corpus["train"]):
                train = sweep_training_clips(face, corpus, n, root)
                out[sweep_face(face, n)] = {**settings, "corpus": {**corpus, "train": train}}
    return out


def sweep_training_clips(face: str, corpus: Mapping, n: int, root: Path) -> list[str]:
    """The first ``n`` of the face's training clips, then of the transcript table's other
    clips that are not test clips (in name order): never a test clip.

    Parameters
    ----------
    face : str
        The face's name (for the message).
    corpus : Mapping
        The face's corpus settings as configured.
    n : int
        How many training clips.
    root : Path
        The project directory.

    Returns
    -------
    list of str
        ``n`` clip ids.

    Raises
    ------
    ConfigError
        When the table has fewer than ``n`` clips that are not test clips.
    """
    train = list(corpus["train"])
    if n <= len(train):
        return train[:n]
    taken = set(train) | set(corpus["test"])
    transcripts = Path(corpus["transcripts"])
    transcripts = transcripts if transcripts.is_absolute() else root / transcripts
    others = sorted(set(read_transcripts(transcripts)) - taken)
    if len(train) + len(others) < n:
        raise ConfigError(
            f"sweeps.training_clips: {n} clips for faces.{face}, but its transcript table has "
            f"only {len(train) + len(others)} clips that are not test clips"
        )
    return train + others[: n - len(train)]


def sweep_of(face: str, all_faces: Mapping[str, Mapping], counts: Sequence[int]) -> dict[int, str]:
    """A face's training-clips sweep, {number of clips: face}, the face itself last (or {}).

    Parameters
    ----------
    face : str
        A configured face.
    all_faces : Mapping
        Every face, the sweep's included (:func:`training_sweep_faces`).
    counts : sequence of int
        ``sweeps.training_clips``.

    Returns
    -------
    dict
        Empty when the face has no sweep.
    """
    sweep = {n: sweep_face(face, n) for n in counts if sweep_face(face, n) in all_faces}
    if not sweep:
        return {}
    return {**sweep, len(all_faces[face]["corpus"]["train"]): face}


def sweep_methods(sweeps: Mapping, methods: Mapping[str, Mapping]) -> dict[str, dict]:
    """Flow methods of the pyramid-depth sweep: ``<estimator>-L<levels>``.

    Parameters
    ----------
    sweeps : Mapping
        The config's ``sweeps``.
    methods : Mapping
        ``flow.methods``: a swept estimator configured there keeps its other settings.

    Returns
    -------
    dict
        ``{name: {"estimator": ..., "settings": {..., "levels": levels}}}``, estimator by
        estimator, depth by depth.
    """
    out = {}
    for estimator in sweeps["level_estimators"]:
        base = dict(methods.get(estimator, {}).get("settings", {}))
        for levels in sweeps["pyramid_levels"]:
            out[f"{estimator}-L{levels}"] = {
                "estimator": estimator,
                "settings": {**base, "levels": levels},
            }
    return out


def sync_sweep_points(sweeps: Mapping, lipsync: Mapping) -> list[Point]:
    """(sampling, px, fps) of the sync sweep, sorted.

    In each mode of ``sweeps.sampling``, one setting at a time: each max_px_per_frame at
    ``lipsync.fps``, each fps at the configured max_px_per_frame (none when that is null:
    no limit to sweep fps at).

    Parameters
    ----------
    sweeps, lipsync : Mapping
        The config's ``sweeps`` and ``lipsync``.

    Returns
    -------
    list of tuple
        The points, each once.
    """
    points = set()
    for sampling in sweeps["sampling"]:
        points |= {(sampling, px, lipsync["fps"]) for px in sweeps["max_px_per_frame"]}
        if lipsync["max_px_per_frame"] is not None:
            points |= {(sampling, lipsync["max_px_per_frame"], fps) for fps in sweeps["fps"]}
    return sorted(points)


def is_configured_point(lipsync: Mapping, sampling: str, px: float, fps: float) -> bool:
    """Whether a sweep point is a face's configured sampling, max_px_per_frame and fps, with
    the paper's model (the one the sweeps study): its utterance is then the face's own.

    Parameters
    ----------
    lipsync : Mapping
        The face's lip-sync settings (the config's, with its own overrides).
    sampling, px, fps
        The point.

    Returns
    -------
    bool
    """
    return lipsync["model"] == PAPER and (sampling, px, fps) == (
        lipsync["sampling"],
        lipsync["max_px_per_frame"],
        lipsync["fps"],
    )


def sweep_lipsync(lipsync: Mapping, sampling: str) -> dict:
    """The lip-sync settings of a sweep utterance: the face's in ``sampling``, with the
    paper's model whatever the face's own (the sweeps study the paper's sampling).

    Parameters
    ----------
    lipsync : Mapping
        The face's lip-sync settings.
    sampling : str
        The sweep point's sampling mode.

    Returns
    -------
    dict
        Canonical (:func:`~miketalk_lab.workflow.config.canonical`): a param.
    """
    return canonical({**lipsync, "sampling": sampling, "model": PAPER, "trajectory": None})


def strip_max_px(lipsync: Mapping) -> float:
    """The max_px_per_frame of the sampling strip: ``lipsync``'s, or the default for none."""
    px = lipsync["max_px_per_frame"]
    return defaults.MAX_PX_PER_FRAME if px is None else px
