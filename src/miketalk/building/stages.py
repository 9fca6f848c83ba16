"""The stages of a face from clips (or from one video), one function each.

The workflow's rules (``workflow/scripts``) and ``miketalk build`` call the same
functions, so a model built by the command is the workflow's model:

1. :func:`miketalk.corpus.one_video.segment_video` (a face from one video only);
2. :func:`corpus_stage`: the training clips into the corpus folder;
3. :func:`miketalk.corpus.viseme_choice.choose_visemes_stage`: the viseme images;
4. :func:`eigenlips_stage`: the corpus's eigenlips;
5. :func:`flows_stage`: a flow database (per method and strategy);
6. :func:`model_stage`: the model directory.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import pandas as pd

from miketalk.corpus.one_video import MIN_VISEME_CLASSES
from miketalk.errors import MiketalkError
from miketalk.track.crop import FaceCropSettings

__all__ = [
    "MIN_VISEME_CLASSES",
    "check_viseme_classes",
    "corpus_stage",
    "eigenlips_stage",
    "flows_stage",
    "model_stage",
    "viseme_classes",
]


def corpus_stage(
    corpus_dir: str | Path,
    corpus: Mapping,
    *,
    segments: str | Path | None = None,
    workers: int = 1,
    crop: FaceCropSettings | None = None,
) -> dict:
    """The training clips of a face (or its one video's training utterances) into its corpus.

    ``corpus`` is the face's corpus settings (paths absolute); ``segments`` the
    ``segments.json`` of a face from one video, whose training part must show
    :data:`MIN_VISEME_CLASSES` viseme classes (:func:`check_viseme_classes`), and whose
    recognized words heard without confidence are recorded (:func:`~miketalk.corpus.unsure.
    write_unsure`: ``unsure.tsv``, left out of the trained face's fits); ``crop``
    the face crop to work in (:func:`miketalk.corpus.clips.ingest_clips`).
    """
    from miketalk.corpus.clips import ingest_clips
    from miketalk.corpus.one_video import face_clips
    from miketalk.corpus.unsure import write_unsure

    clips = face_clips(dict(corpus), "train", segments=segments)
    report = ingest_clips(Path(corpus_dir), clips=clips, workers=workers, crop=crop)
    if segments is not None:  # a face from one video: its utterances must show the classes
        check_viseme_classes(corpus_dir)
        write_unsure(corpus_dir, segments)  # the spans of words heard without confidence
    return report


def viseme_classes(corpus_dir: str | Path, *, grouping: Mapping | None = None) -> set[str]:
    """The viseme classes the corpus's aligned phones show (silence left out)."""
    from miketalk.corpus.clips import PHONES_TABLE
    from miketalk.visemes import VisemeTable

    phones = pd.read_csv(Path(corpus_dir) / PHONES_TABLE, sep="\t", keep_default_na=False)
    return VisemeTable(grouping=dict(grouping or {})).spoken_visemes(phones["phone"])


def check_viseme_classes(corpus_dir: str | Path, *, grouping: Mapping | None = None) -> None:
    """Refuse a corpus whose speech shows fewer than :data:`MIN_VISEME_CLASSES` classes.

    Raises
    ------
    MiketalkError
        Naming how many classes and how much speech there is.
    """
    from miketalk.corpus.clips import CLIPS_TABLE

    found = viseme_classes(corpus_dir, grouping=grouping)
    if len(found) < MIN_VISEME_CLASSES:
        clips = pd.read_csv(Path(corpus_dir) / CLIPS_TABLE, sep="\t", keep_default_na=False)
        raise MiketalkError(
            f"too little speech for the viseme classes: the training part "
            f"({clips['duration'].sum():.1f} s in {len(clips)} utterances) shows "
            f"{len(found)} of the classes, at least {MIN_VISEME_CLASSES} are needed: "
            "give a longer video"
        )


def eigenlips_stage(corpus_dir: str | Path, out: str | Path) -> None:
    """The corpus's eigenlips, fitted once for its model and its held-out test."""
    from miketalk.corpus.eigenlips import fit_corpus_eigenlips, write_eigenlips

    write_eigenlips(out, fit_corpus_eigenlips(Path(corpus_dir)))


def flows_stage(
    flows: str | Path,
    choices: str | Path,
    *,
    visemes: str | Path,
    images: str | Path,
    frames: str | Path,
    spec: Mapping,
    strategy: str,
    window: int,
    mixed: str | Path | None = None,
    regions: str | Path | None = None,
    workers: int = 1,
) -> None:
    """One flow database (``flows``) and its table of choices (``choices``).

    ``spec`` is the method's ``estimator`` and ``settings``; ``mixed`` the
    database a refining strategy reads; ``regions`` a face from clips's
    ``regions.json`` (flows around the mouth only).
    """
    from miketalk.flow.build import build_flow_database
    from miketalk.media.atomic import write_text_atomic
    from miketalk.mouth import flow_region

    table = pd.read_csv(visemes, sep="\t", keep_default_na=False)
    chosen = build_flow_database(
        flows,
        visemes=table,
        images_dir=Path(images),
        frames_dir=Path(frames),
        estimator=spec["estimator"],
        settings=spec["settings"],
        strategy=strategy,
        window=window,
        mixed=mixed,
        region=flow_region(Path(regions).parent) if regions else None,
        workers=workers,
    )
    write_text_atomic(choices, chosen.to_csv(sep="\t", index=False))


def model_stage(
    out: str | Path,
    *,
    visemes: str | Path,
    images: str | Path,
    flows: str | Path,
    spec: Mapping,
    strategy: str,
    grouping: Mapping,
    phones: str | Path | None = None,
    eigenlips: str | Path | None = None,
    media: str | None = None,
    segments: str | Path | None = None,
) -> None:
    """Assemble the model directory ``out``; a face from clips also learns from its frames.

    ``phones`` and ``eigenlips`` are a face from clips's corpus files (its
    coarticulation and trained face are fitted); ``media`` its clips' media (its
    person's own frames become the model's background, for say and dub), with
    ``segments`` for a face from one video.
    """
    from miketalk.model.write import build_model, fallbacks_of, list_model_files

    table = pd.read_csv(visemes, sep="\t", keep_default_na=False)
    paths = {
        v: Path(images) / name for v, name in zip(table["viseme"], table["image"], strict=True)
    }
    build_model(
        out,
        images=paths,
        flows_dir=flows,
        estimator=spec["estimator"],
        settings={**spec["settings"], "strategy": strategy},
        fallbacks=fallbacks_of(table),
    )
    if phones:  # a face from clips: learn from its frames
        from miketalk.building.background import write_background
        from miketalk.building.lipsync_choice import fit_and_choose
        from miketalk.corpus.eigenlips import read_eigenlips
        from miketalk.draw.coarticulation import fit_coarticulation
        from miketalk.model.face import Model
        from miketalk.model.write import write_coarticulation

        corpus = Path(phones).parent
        with Model(out) as model:
            images = {v: model.image(v) for v in model.visemes}
        params = fit_coarticulation(
            corpus, images, grouping=dict(grouping), corpus_eigenlips=read_eigenlips(eigenlips)
        )
        write_coarticulation(out, params)
        fit_and_choose(corpus, out, grouping=dict(grouping))  # the trained face, the choice
        if media:  # its person's own frames, for say and dub
            write_background(out, corpus_dir=corpus, media=media, segments=segments)
    list_model_files(out)  # last: every part listed, checked when the model opens
