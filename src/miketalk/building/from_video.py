"""A talking-face model from one video of a person and what it says: the workflow's stages for
a face from one video (:mod:`miketalk.building.stages`), one after the other.

The work is done in a folder beside the model directory that is removed at the end, the
model's lock held throughout (a second build of it is refused before its work); the model
directory appears only when the model is complete, and replaces an older model only with
``force`` and only when the older one holds nothing but its own files (those its manifest
names, :func:`miketalk.media.ownership.check_replaceable`). ``MODEL_DIR/build/`` keeps the
utterances found (``segments.json``) and the corpus's tables of what was left out. Bad input
is one line (:class:`MiketalkError`), before the long work where it can be: no video or no
sound, no face or several, no speech, a transcript in another language or of another video,
too little speech for the viseme classes.
"""

from __future__ import annotations

import argparse
import contextlib
import shutil
import sys
import time
from collections.abc import Iterator
from pathlib import Path

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.media.atomic import check_writable, output_lock
from miketalk.media.ownership import Kind, check_replaceable
from miketalk.media.scratch import scratch_dir
from miketalk.track.crop import FaceCropSettings
from miketalk.workers import check_workers, default_workers, one_blas_thread

__all__ = ["KEPT", "build_model_from_video", "peak_mb", "publish_directory"]

#: What MODEL_DIR/build/ keeps of the work.
KEPT = {"segments.json": "segments", "skipped.tsv": "corpus", "clips.tsv": "corpus"}


def build_model_from_video(
    video: str | Path,
    model_dir: str | Path,
    *,
    transcript: str | Path | None = None,
    subtitles: str | Path | None = None,
    heldout_seconds: float = defaults.HELDOUT_SECONDS,
    workers: int | None = None,
    force: bool = False,
    progress: bool = True,
    report=None,
    flow: dict | None = None,
    mixed_window: int = defaults.BUILD_MIXED_WINDOW,
    keep_corpus: str | Path | None = None,
    crop: FaceCropSettings | None = FaceCropSettings(),  # noqa: B008 (frozen: one value)
) -> dict:
    """Build a model from one video (see the module docstring); the seconds each stage took.

    ``workers``: processes to use, 1 to the machine's cores (None: two, or one on a machine
    of one core). ``report(stage, seconds, peak_mb)`` is called after each stage (``peak_mb``: the
    largest memory the build's process, or a process it started, has held so far).
    ``flow`` (the flow method's ``estimator`` and ``settings``) and ``mixed_window``
    default to the workflow's defaults; ``keep_corpus`` is where the corpus folder is moved at
    the end (for a held-out test of the model; a new folder), instead of removed.
    ``crop``: the face tracked and the model built in its canonical crop of this geometry
    (:mod:`miketalk.track`), its output at the video's own resolution; None: in the
    video's own pixels (the plain-background rules of :mod:`miketalk.stabilize`).

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
    from miketalk.model.write import list_model_files

    model_dir = Path(model_dir)
    workers = default_workers() if workers is None else check_workers(workers)
    inputs = [video, transcript, subtitles]
    check_replaceable(model_dir, Kind.MODEL, inputs=inputs, force=force)
    try:
        check_writable(model_dir)  # its folder: before the work, not after it
    except MiketalkError as err:
        raise MiketalkError(f"{err}; give another -o") from None
    if keep_corpus is not None and Path(keep_corpus).exists():
        raise MiketalkError(f"{keep_corpus} exists: --keep-corpus needs a new folder")
    # one BLAS thread, as the command line runs it: the build's own workers share the cores
    # and OpenBLAS's threads spin (the trained face's fits took 7.6 s of CPU with two
    # threads and 0.9 s with one)
    with _model_lock(model_dir), one_blas_thread():  # another build: refused before any check
        checked = check_video_inputs(  # before any work: one line for a bad video or script
            video, transcript=transcript, subtitles=subtitles, heldout_seconds=heldout_seconds
        )
        with _work_folder(model_dir) as work:
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
                "corpus": lambda: corpus_stage(
                    corpus, settings, segments=segments, workers=workers, crop=crop
                ),
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
            list_model_files(work / "model")  # its record too: --force replaces only what it names
            check_replaceable(model_dir, Kind.MODEL, inputs=inputs, force=force)  # under its lock
            publish_directory(work / "model", model_dir)
            if keep_corpus is not None:
                Path(keep_corpus).parent.mkdir(parents=True, exist_ok=True)
                shutil.move(corpus, keep_corpus)
    return seconds


@contextlib.contextmanager
def _model_lock(model_dir: Path) -> Iterator[None]:
    """Hold the model's lock from before the build's checks to its end, or refuse at once when
    another process holds it (:func:`output_lock`): a second build of the same model is
    refused before its work, not when it publishes. The folders made for the lock are
    removed again when the build fails and they are empty."""
    made = [p for p in model_dir.absolute().parents if not p.exists()]
    try:
        model_dir.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise MiketalkError(
            f"cannot write the model {model_dir}: {err.strerror or err} "
            f"({model_dir.parent}); give another -o"
        ) from None
    try:
        with output_lock(model_dir, wait=False):
            yield
    except BaseException:
        for folder in made:  # the deepest first
            try:
                folder.rmdir()
            except OSError:  # not empty
                break
        raise


@contextlib.contextmanager
def _work_folder(model_dir: Path) -> Iterator[Path]:
    """The work folder beside the model (the model is renamed out of it; swept if killed);
    a folder that cannot be written in is one line."""
    with contextlib.ExitStack() as stack:
        try:
            work = stack.enter_context(scratch_dir("build", directory=model_dir.parent))
        except OSError as err:
            raise MiketalkError(
                f"cannot write the model {model_dir}: {err.strerror or err} "
                f"({model_dir.parent}); give another -o"
            ) from None
        yield work


def publish_directory(new: Path, final: Path) -> None:
    """Put the directory ``new`` at ``final`` in one step; an old ``final`` takes ``new``'s place.

    Both in one file system. An old directory is exchanged with the new one atomically
    (``renameat2`` with ``RENAME_EXCHANGE``, Linux 3.15 and later), so that ``final`` is the
    old model or the new one at every moment; the old one is then at ``new`` (removed with
    the work folder). Where the exchange is not possible, the old directory is renamed aside
    first (a kill between the two renames leaves it there, beside ``final``).
    """
    if not final.exists():
        new.rename(final)
        return
    if _exchange(new, final):
        return
    aside = new.with_name(new.name + ".replaced")
    final.rename(aside)
    try:
        new.rename(final)
    except BaseException:
        aside.rename(final)
        raise
    aside.rename(new)


def _exchange(a: Path, b: Path) -> bool:
    """``renameat2(a, b, RENAME_EXCHANGE)``; False where the system cannot."""
    import ctypes
    import os

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, exchange = -100, 2
    done = renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), exchange)
    return done == 0


def peak_mb() -> float:
    """The largest resident memory (MB) this process or a waited-for child has held."""
    import resource

    who = (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)
    return max(resource.getrusage(w).ru_maxrss for w in who) / 1024
