"""Which faces are what kind: where a face's recording comes from decides its rules.

A face's settings are its entry in the config's ``faces`` (its ``corpus`` with the
schema's defaults filled in). Three sources (the schema's ``corpus.source``):

- ``synthetic``: the parametric face speaking the paper's corpus words (its true motion
  is known: the measurements against truth use the first one);
- ``video``: one video of a person, either of the corpus words (``video``) or of any speech
  (``media`` with its transcript or subtitles), which is cut into utterances and then
  treated like clips;
- ``clips``: clips of one person's ordinary speech (``media``, ``transcripts``, ``train``,
  ``test``).
"""

from __future__ import annotations

from collections.abc import Mapping

#: The sources of a face's recording (the schema's ``corpus.source``).
SYNTHETIC = "synthetic"
VIDEO = "video"
CLIPS = "clips"


def source(settings: Mapping) -> str:
    """Where a face's recording comes from: :data:`SYNTHETIC`, :data:`VIDEO` or :data:`CLIPS`.

    Parameters
    ----------
    settings : Mapping
        The face's config entry.

    Returns
    -------
    str
        Its ``corpus.source``.
    """
    return settings["corpus"]["source"]


def is_one_video(settings: Mapping) -> bool:
    """Whether a face's corpus is one video of any speech (source video with media)."""
    return source(settings) == VIDEO and bool(settings["corpus"].get("media"))


def speaks_corpus_words(settings: Mapping) -> bool:
    """Whether a face was recorded speaking the paper's corpus words (synthetic, or a
    person's video of them)."""
    return source(settings) in (SYNTHETIC, VIDEO) and not is_one_video(settings)


def is_from_clips(settings: Mapping) -> bool:
    """Whether a face is built from clips of ordinary speech (the utterances of one video
    too)."""
    return source(settings) == CLIPS or is_one_video(settings)


def has_test(settings: Mapping) -> bool:
    """Whether a face from clips (or one video) has held-out clips to measure."""
    corpus = settings["corpus"]
    if is_one_video(settings):
        return corpus["heldout_seconds"] > 0
    return corpus["source"] == CLIPS and bool(corpus["test"])


def first_test_clip(settings: Mapping) -> str | None:
    """The clip of a face's held-out figures (None: the first one measured, for one video)."""
    return None if is_one_video(settings) else settings["corpus"]["test"][0]


def truth_face(faces: Mapping[str, Mapping]) -> str | None:
    """The face every measurement against ground truth uses: the first synthetic one.

    Parameters
    ----------
    faces : Mapping
        Settings by face name, in config order.

    Returns
    -------
    str or None
        Its name; None without a synthetic face.
    """
    return next((f for f, settings in faces.items() if source(settings) == SYNTHETIC), None)


def figure_face(faces: Mapping[str, Mapping]) -> str:
    """The face of the figures drawn from a model (the lip-sync diagram, the morph strip):
    the truth face, else the first one."""
    return truth_face(faces) or next(iter(faces))
