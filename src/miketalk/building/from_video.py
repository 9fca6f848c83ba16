"""A talking-face model from one video of a person and what it says: the workflow's stages for
a face from one video (:mod:`miketalk.building.stages`), one after the other.

The work is done in a folder beside the model directory that is removed at the end; the
model directory appears only when the model is complete (and replaces an older model only
with ``force``). ``MODEL_DIR/build/`` keeps the utterances found (``segments.json``) and the
corpus's tables of what was left out. Bad input is one line (:class:`MiketalkError`),
before the long work where it can be: no video or no sound, no face or several, no speech,
a transcript in another language or of another video, too little speech for the viseme
classes.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from pathlib import Path

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.media.scratch import scratch_dir

__all__ = ["KEPT", "build_model_from_video", "peak_mb"]

#: What MODEL_DIR/build/ keeps of the work.
KEPT = {"segments.json": "segments", "skipped.tsv": "corpus", "clips.tsv": "corpus"}


def build_model_from_video(
    video: str | Path,
    model_dir: str | Path,
    *,
    transcript: str | Path | None = None,
    subtitles: str | Path | None = None,
    heldout_seconds: float = defaults.HELDOUT_SECONDS,
    workers: int = 2,
    force: bool = False,
    progress: bool = True,
    report=None,
    flow: dict | None = None,
    mixed_window: int = defaults.BUILD_MIXED_WINDOW,
    keep_corpus: str | Path | None = None,
) -> dict:
    """Build a model from one video (see the module docstring); the seconds each stage took.

    ``report(stage, seconds, peak_mb)`` is called after each stage (``peak_mb``: the
    largest memory the build's process, or a process it started, has held so far).
    ``flow`` (the flow method's ``estimator`` and ``settings``) and ``mixed_window``
    default to the workflow's defaults; ``keep_corpus`` is where the corpus folder is moved at
    the end (for a held-out test of the model; a new folder), instead of removed.

    Raises
    ------
    MiketalkError
        Bad input (one line), or MODEL_DIR holding something else than a model.
    """
    from tqdm import tqdm

    from miketalk.building.stages import (
        corpus_stage,
        eigenlips_stage,
        flows_stage,
        model_stage,
    )
    from miketalk.corpus.one_video import check_video_inputs, segment_video
    from miketalk.corpus.viseme_choice import choose_visemes_stage

    model_dir = Path(model_dir)
    if model_dir.exists():
        if not force or not (model_dir / "manifest.json").is_file():
            what = "a model" if (model_dir / "manifest.json").is_file() else "something else"
            raise MiketalkError(
                f"{model_dir} exists and holds {what}: give another -o"
                + (" or --force to replace it" if what == "a model" else "")
            )
    if keep_corpus is not None and Path(keep_corpus).exists():
        raise MiketalkError(f"{keep_corpus} exists: --keep-corpus needs a new folder")
    checked = check_video_inputs(  # before any work: one line for a bad video or script
        video, transcript=transcript, subtitles=subtitles, heldout_seconds=heldout_seconds
    )
    model_dir.parent.mkdir(parents=True, exist_ok=True)
    # the work folder beside the model (the model is renamed out of it), swept if killed
    with scratch_dir("build", directory=model_dir.parent) as work:
        spec, strategy = flow or defaults.BUILD_FLOW_METHOD, defaults.BUILD_FLOW_STRATEGY
        corpus, visemes, flows = work / "corpus", work / "visemes", work / "flows"
        segments = work / "segments" / "segments.json"
        settings = {"media": str(Path(video).resolve())}
        out = argparse.Namespace(
            targets=visemes / "candidates.tsv",
            visemes=visemes / "visemes.tsv",
            images=visemes / "images",
            sheet=visemes / "contact_sheet.png",
        )

        def flows_of(name: str, mixed: Path | None = None) -> None:
            flows_stage(
                flows / name,
                flows / f"{name}.tsv",
                visemes=out.visemes,
                images=out.images,
                frames=corpus / "frames",
                spec=spec,
                strategy=name,
                window=mixed_window,
                mixed=mixed,
                regions=corpus / "regions.json",
                workers=workers,
            )

        steps = {
            "segment": lambda: segment_video(
                video, segments, transcript=transcript, subtitles=subtitles,
                heldout_seconds=heldout_seconds, checked=checked,
            ),
            "corpus": lambda: corpus_stage(corpus, settings, segments=segments, workers=workers),
            "visemes": lambda: choose_visemes_stage(corpus_dir=corpus, grouping={}, out=out),
            "eigenlips": lambda: eigenlips_stage(corpus, corpus / "eigenlips.npz"),
            "flows (mixed)": lambda: flows_of("mixed"),
            "flows (bridge)": lambda: flows_of(strategy, mixed=flows / "mixed"),
            "model": lambda: model_stage(
                work / "model", visemes=out.visemes, images=out.images, flows=flows / strategy,
                spec=spec, strategy=strategy, grouping={}, phones=corpus / "phones.tsv",
                eigenlips=corpus / "eigenlips.npz", media=settings["media"], segments=segments,
            ),
        }  # fmt: skip
        seconds: dict[str, float] = {}
        out.visemes.parent.mkdir(parents=True)
        segments.parent.mkdir(parents=True)
        bar = tqdm(total=len(steps), unit="stage", disable=not progress, file=sys.stderr)
        with bar:
            for name, step in steps.items():
                bar.set_description(f"build: {name}")
                started = time.perf_counter()
                step()
                seconds[name] = time.perf_counter() - started
                bar.update(1)
                if report is not None:
                    report(name, seconds[name], peak_mb())
        kept = work / "model" / "build"
        kept.mkdir()
        for name, where in KEPT.items():
            shutil.copyfile(work / where / name, kept / name)
        if model_dir.exists():  # --force: the old model is moved aside, removed with the work
            model_dir.rename(work / "replaced")
        (work / "model").rename(model_dir)
        if keep_corpus is not None:
            Path(keep_corpus).parent.mkdir(parents=True, exist_ok=True)
            shutil.move(corpus, keep_corpus)
    return seconds


def peak_mb() -> float:
    """The largest resident memory (MB) this process or a waited-for child has held."""
    import resource

    who = (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)
    return max(resource.getrusage(w).ru_maxrss for w in who) / 1024
