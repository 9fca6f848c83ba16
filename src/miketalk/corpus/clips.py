"""A corpus of ordinary speech: video clips of one person, their transcripts, optional word timings.

The convention phoneticians use with forced aligners: one media file per
utterance and a table of ``id text`` lines (GRID's ``transcripts.txt``), with
word timings beside them when known (GRID ``.align`` or Praat ``.TextGrid``),
all named by the clip's id through patterns such as ``video/{id}.mpg``.

:func:`ingest_clips` brings the training clips into the corpus folder
(:mod:`miketalk.corpus.folder`), in this order:

1. each clip is decoded (frames and 16 kHz mono sound);
2. its phones are aligned to the sound (:func:`miketalk.speech.align.align_phones`,
   inside the given word timings when there are any);
3. every frame of every clip is registered to one reference frame on the face
   outside the mouth (:mod:`miketalk.stabilize`) and warped onto it, so
   nothing after this stage sees the head move; frames before or after the
   speech that do not register are left out (:mod:`miketalk.corpus.steady`);
4. the clips are written one after the other as one recording: frames
   numbered on, each clip's sound fitted to its frames (padded with silence or
   trimmed to ``n_frames / fps``), its phones shifted by its start time.

Besides the corpus folder's files it writes ``clips.tsv`` (where each clip
starts), ``phones.tsv`` (every aligned phone, recording time and clip time),
``stabilization.tsv`` (each frame's registration: correlation and transform),
``regions.json`` with ``face_mask.png`` and ``mouth_mask.png`` (where the face
and the mouth are, found in the reference clip), ``reference.png`` and
``registration_mask.png`` (what :func:`corpus_stabilizer` registers other
recordings of the same person with), and ``skipped.tsv``.

A clip that cannot be used (no sound, a word the aligner cannot place, fewer
frames than its phones need, a face that will not register during its speech, a
missing timing file) is skipped, named in a warning and in ``skipped.tsv``: one bad clip of
many should not cost the model, and the table says what was left out. The run
stops (:class:`~miketalk.errors.MiketalkError`) when no clip is left, and for
mistakes in the configuration itself (a transcript table or media file that
does not exist, an id the table lacks, clips of different sizes or frame rates).
"""

from __future__ import annotations

import csv
import functools
import io
import json
import logging
import shutil
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

import numpy as np

from miketalk.corpus.clip_sources import (
    RATE,
    Clip,
    ClipError,
    DecodedClip,
    _clipped,
    _words,
    decode_clip,
)
from miketalk.corpus.folder import (
    AUDIO,
    FRAMES,
    FRAMES_TABLE,
    TRUTH,
    VIDEO,
    WORDS,
    empty_truth_text,
    frame_path,
    words_doc,
)
from miketalk.corpus.light import match_light
from miketalk.errors import MiketalkError
from miketalk.media.atomic import write_text_atomic
from miketalk.media.audio import write_wav
from miketalk.media.images import read_image, write_png
from miketalk.mouth.region import REGIONS, mouth_box
from miketalk.track.crop import FaceCropSettings, crop_doc, crop_from_doc, face_mask

log = logging.getLogger(__name__)


CLIPS_TABLE = "clips.tsv"


PHONES_TABLE = "phones.tsv"


STABILIZATION_TABLE = "stabilization.tsv"


SKIPPED_TABLE = "skipped.tsv"


#: Each clip's media file and span in it, in a face crop's corpus and in a corpus of a video's
#: parts (its utterances, and their pieces cut at a shot change or a frame left out).
SOURCES_TABLE = "sources.tsv"


FACE_MASK = "face_mask.png"


MOUTH_MASK = "mouth_mask.png"


REFERENCE = "reference.png"


REGISTRATION_MASK = "registration_mask.png"

#: A face crop's clips matched to the reference's light by gain and offset (True) or
#: offset only (False): see :mod:`miketalk.corpus.light`.
LIGHT_SPREAD = False


def ingest_clips(
    out_dir: str | Path,
    *,
    clips: Sequence[Clip],
    decode: Callable[[Clip], DecodedClip] | None = None,
    workers: int = 1,
    crop: FaceCropSettings | None = None,
) -> dict:
    """Write the corpus folder of ``clips`` (see the module docstring).

    Parameters
    ----------
    out_dir : path
        The corpus folder to fill.
    clips : sequence of Clip
        The training clips, in the order they are written.
    decode : callable, optional
        ``decode(clip) -> DecodedClip`` (:func:`decode_clip` with ``crop``; tests pass
        a fake).
    workers : int
        Clips decoded and aligned at once (threads: decoding runs in ffmpeg
        and the aligner's C code).
    crop : FaceCropSettings, optional
        Work in the face's canonical crop (:mod:`miketalk.track`): the face is tracked
        in each clip, the corpus's frames are its crops, and the face mask the
        registration uses is the crop's (:func:`~miketalk.track.crop.face_mask`)
        instead of the plain-background and skin-colour rules. None: the frames as
        recorded.

    Returns
    -------
    dict
        ``clips``, ``frames``, ``skipped`` counts and the reference clip.

    Raises
    ------
    MiketalkError
        When no clip can be used, or the clips differ in size or frame rate.
    """
    from miketalk.corpus.steady import stabilize_clip
    from miketalk.media.video import write_mp4
    from miketalk.stabilize import Stabilizer, choose_reference

    if not clips:
        raise MiketalkError("no clips to build a corpus from")
    out = Path(out_dir)
    frames_dir = out / FRAMES
    if frames_dir.exists():
        shutil.rmtree(frames_dir)
    frames_dir.mkdir(parents=True)
    skipped: list[tuple[str, str]] = []
    if decode is None:
        decode = functools.partial(decode_clip, crop=crop)
    decoded = _shots(_decoded(clips, decode, skipped, workers), skipped)

    stabilizer = None
    size = fps = None
    rows_clips, rows_phones, rows_stab, audio, words = [], [], [], [], []
    rows_sources: list[tuple] = []  # a face crop's, a video's parts': where each clip is in it
    n_total = 0
    regions: dict = {}
    for item in decoded:
        clip = item.clip
        if size is None:
            size, fps = item.frames.shape[1:3], item.fps
            reference = int(choose_reference(item.frames))
            try:
                if crop is None:
                    stabilizer = Stabilizer.from_reference(
                        item.frames[reference], sample=item.frames
                    )
                else:  # the crop's face: its mask and mouth where the similarity puts them
                    stabilizer = crop_stabilizer(item.frames[reference], crop)
            except MiketalkError as err:
                raise MiketalkError(
                    f"clip {clip.id}, the reference clip: its face cannot be found ({err})"
                ) from err
            face, mouth, mask = stabilizer.face, stabilizer.mouth_box, stabilizer.mask
            regions = {
                "reference": {"clip": clip.id, "frame": reference},
                "mouth_box": list(mouth),
                "size": [int(size[0]), int(size[1])],
            }
            if crop is not None:  # and where its shot is in the video
                regions["crop"] = crop_doc(crop)
                regions["reference"] |= _where(item)
            write_png(out / REFERENCE, item.frames[reference])
            write_png(out / REGISTRATION_MASK, (mask * 255).astype(np.uint8))
            write_png(out / FACE_MASK, (face * 255).astype(np.uint8))
            write_png(out / MOUTH_MASK, _box_mask(size, mouth))
        elif item.frames.shape[1:3] != size or abs(item.fps - fps) > 1e-6:
            raise MiketalkError(
                f"clip {clip.id} is {item.frames.shape[2]}x{item.frames.shape[1]} at "
                f"{item.fps:g} fps, the first clip {size[1]}x{size[0]} at {fps:g}: the clips of "
                "one corpus must share size and frame rate"
            )
        try:
            item, stabilized = stabilize_clip(item, stabilizer)
        except MiketalkError as err:
            _skip(skipped, clip, str(err))
            continue
        steady, transforms, scores = (
            stabilized.frames,
            stabilized.transforms,
            stabilized.correlations,
        )
        if crop is not None:  # shots of other days and lamps: one light for the corpus
            steady, gain, offset = match_light(
                steady, stabilizer.reference, stabilizer.mask, spread=LIGHT_SPREAD
            )
            log.info("clip %s: light matched (gain %s, offset %s)", clip.id,
                     np.round(gain, 2).tolist(), np.round(offset, 1).tolist())  # fmt: skip
        first, n = n_total, len(steady)
        for k, frame in enumerate(steady):
            write_png(frame_path(frames_dir, first + k), frame)
        offset = first / fps
        duration = n / fps
        audio.append(_fit(item.samples, round(duration * RATE)))
        phones = _clipped(item.phones, duration)
        rows_clips.append((clip.id, first, n, f"{offset:.6f}", f"{duration:.6f}", clip.text))
        if crop is not None or clip.span is not None:
            where = _where(item)
            rows_sources.append((clip.id, where["media"], where.get("first_frame", 0), n, item.fps))
        for i, p in enumerate(phones):
            rows_phones.append(
                (clip.id, i, p.name, f"{p.start + offset:.6f}", f"{p.end + offset:.6f}",
                 f"{p.start:.6f}", f"{p.end:.6f}")
            )  # fmt: skip
        for k, (t, score) in enumerate(zip(transforms, scores, strict=True)):
            rows_stab.append(
                (clip.id, k, first + k, f"{score:.5f}", *(f"{v:.6f}" for v in t.ravel()))
            )
        words += _words(clip.id, item.words, phones, offset)
        n_total += n
    if not rows_clips:
        raise MiketalkError(
            f"no usable clip among {len(clips)}: " + "; ".join(f"{c}: {why}" for c, why in skipped)
        )
    samples = np.concatenate(audio)
    write_wav(out / AUDIO, samples, RATE)
    write_table(
        out / CLIPS_TABLE,
        ("clip", "first_frame", "frames", "start", "duration", "text"),
        rows_clips,
    )
    write_table(
        out / PHONES_TABLE,
        ("clip", "index", "phone", "start", "end", "clip_start", "clip_end"),
        rows_phones,
    )
    write_table(
        out / STABILIZATION_TABLE,
        ("clip", "clip_frame", "frame", "correlation", "a11", "a12", "b1", "a21", "a22", "b2"),
        rows_stab,
    )
    write_table(out / SKIPPED_TABLE, ("clip", "reason"), skipped)
    if crop is not None or rows_sources:
        write_table(out / SOURCES_TABLE, ("clip", "media", "first_frame", "frames", "fps"),
                    rows_sources)  # fmt: skip
    table = ["frame\ttime\tclip\tclip_frame"]
    for clip_id, first, n, *_ in rows_clips:
        table += [f"{first + k}\t{(first + k) / fps:.6f}\t{clip_id}\t{k}" for k in range(n)]
    write_text_atomic(out / FRAMES_TABLE, "\n".join(table) + "\n")
    write_text_atomic(out / TRUTH, empty_truth_text())
    regions["clips"] = len(rows_clips)
    write_text_atomic(out / REGIONS, json.dumps(regions, indent=1))
    write_mp4(  # from the frames written: a long corpus does not wait in memory
        out / VIDEO,
        (read_image(frame_path(frames_dir, k)) for k in range(n_total)),
        fps=fps,
        audio=samples,
        rate=RATE,
        n_frames=n_total,
    )
    doc = words_doc(
        fps=fps, size=[int(size[0]), int(size[1])], rate=RATE, source="clips", words=words
    )
    write_text_atomic(out / WORDS, doc)  # last: the folder is complete once it exists
    log.info("corpus: %d clips, %d frames, %d skipped", len(rows_clips), n_total, len(skipped))
    return {
        "clips": len(rows_clips),
        "frames": n_total,
        "skipped": len(skipped),
        "reference": regions["reference"],
    }


def corpus_stabilizer(corpus_dir: str | Path):
    """The stabilizer the corpus was registered with, for other clips of the same person."""
    from miketalk.media.images import read_image
    from miketalk.stabilize import Stabilizer

    corpus_dir = Path(corpus_dir)
    regions = json.loads((corpus_dir / REGIONS).read_text(encoding="utf-8"))
    crop = crop_from_doc(regions.get("crop"))
    if crop is not None:
        return crop_stabilizer(read_image(corpus_dir / REFERENCE), crop)
    face = read_image(corpus_dir / FACE_MASK)
    face = (face if face.ndim == 2 else face[..., 0]) > 127
    return Stabilizer.from_reference(
        read_image(corpus_dir / REFERENCE), face=face, mouth_box=mouth_box(corpus_dir)
    )


def corpus_decoder(corpus_dir: str | Path) -> Callable[[Clip], DecodedClip]:
    """How the corpus's clips were read, for other clips of the same person (a held-out
    test): :func:`decode_clip` tracked and cropped in the corpus's face crop, or as recorded."""
    regions = json.loads((Path(corpus_dir) / REGIONS).read_text(encoding="utf-8"))
    return functools.partial(decode_clip, crop=crop_from_doc(regions.get("crop")))


def crop_stabilizer(reference: np.ndarray, crop: FaceCropSettings):
    """The stabilizer of a corpus in the face's crop: ECC on the crop's face mask outside
    its mouth (:func:`~miketalk.track.crop.face_mask`, :func:`~miketalk.track.crop.
    mouth_box`), refining the tracker's similarity; no conform field (the faces of other
    sessions, light and days differ by more than a pose: the field followed the light)."""
    from miketalk.stabilize import Stabilizer
    from miketalk.track.crop import mouth_box as crop_mouth_box

    return Stabilizer.from_reference(
        reference, face=face_mask(crop) > 0.5, mouth_box=crop_mouth_box(crop), conform_degree=0
    )


def _decoded(
    clips: Sequence[Clip],
    decode: Callable[[Clip], DecodedClip],
    skipped: list[tuple[str, str]],
    workers: int,
) -> Iterable[DecodedClip]:
    """Decode the clips (``workers`` at a time, in order), skipping the ones that fail."""
    from concurrent.futures import ThreadPoolExecutor

    from miketalk.workers import results

    def attempt(clip: Clip) -> DecodedClip | ClipError:
        try:
            return decode(clip)
        except ClipError as err:
            return err

    from collections import deque

    ahead = 2 * max(1, workers)  # decoded clips wait in memory: a few, not all of them
    pool = ThreadPoolExecutor(max(1, workers), thread_name_prefix="clip")
    try:
        pending: deque = deque()
        queue = iter(clips)
        for clip in queue:
            pending.append((clip, pool.submit(attempt, clip)))
            if len(pending) >= ahead:
                break
        while pending:
            clip, future = pending.popleft()
            result = next(results([future]))  # in slices: a signal is not lost (workers.py)
            if (following := next(queue, None)) is not None:
                pending.append((following, pool.submit(attempt, following)))
            if isinstance(result, ClipError):
                _skip(skipped, clip, str(result))
            else:
                yield result
    except BaseException:  # a stop, an error, the consumer gone: wait for no clip
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()


#: A clip's part between two shot changes shorter than this (s) is left out: a few frames
#: of a shot are no utterance (and no loop for the background).
MIN_SHOT_SECONDS = 0.25


def _shots(decoded: Iterable[DecodedClip], skipped: list[tuple[str, str]]) -> Iterable[DecodedClip]:
    """Each clip cut at its shot changes (:meth:`DecodedClip.shots`) and at the frames left
    out in its speech (:func:`~miketalk.corpus.pieces.speech_pieces`), the parts too short
    or dropped left out and named."""
    from miketalk.corpus.pieces import speech_pieces

    for whole in decoded:
        for part in whole.shots():
            if whole.cuts and len(part.frames) < MIN_SHOT_SECONDS * part.fps:
                n = len(part.frames)
                why = f"a shot of {n} frame{'s' * (n != 1)} (less than {MIN_SHOT_SECONDS:g} s)"
                _skip(skipped, part.clip, why)
                continue
            kept, dropped = speech_pieces(part)
            for clip, why in dropped:
                _skip(skipped, clip, why)
            yield from kept


def _where(item: DecodedClip) -> dict:
    """Where a clip's frames are in its media file."""
    if item.clip.span is None:
        return {"media": str(item.clip.media)}
    return {"media": str(item.clip.media), "first_frame": item.clip.span[0],
            "frames": item.clip.span[1], "fps": item.fps}  # fmt: skip


def _skip(skipped: list[tuple[str, str]], clip: Clip, why: str) -> None:
    """Name a clip left out, in a warning and in ``skipped``: why, and, for a part of a
    longer video, where it is in the video (its frames and seconds), so that a user finds
    what was left out of their video."""
    why = why.removeprefix(f"clip {clip.id}: ")
    if clip.span is not None and clip.fps:
        first, n = clip.span
        why = (f"frames {first}-{first + n - 1} of {clip.media.name} ({first / clip.fps:.2f}-"
               f"{(first + n) / clip.fps:.2f} s): {why}")  # fmt: skip
    log.warning("clip %s skipped: %s", clip.id, why)
    skipped.append((clip.id, why.replace("\t", " ").replace("\n", " ")))


def _fit(samples: np.ndarray, n: int) -> np.ndarray:
    """``samples`` padded with silence or trimmed to ``n``."""
    if len(samples) >= n:
        return samples[:n]
    return np.concatenate([samples, np.zeros(n - len(samples), samples.dtype)])


def _box_mask(size: tuple[int, int], box: tuple[int, int, int, int]) -> np.ndarray:
    x, y, w, h = box
    mask = np.zeros(size, np.uint8)
    mask[y : y + h, x : x + w] = 255
    return mask


def write_table(path: Path, header: Sequence[str], rows: Iterable[Sequence[object]]) -> None:
    """A tab-separated table with its header, written atomically."""
    buf = io.StringIO()
    writer = csv.writer(buf, delimiter="\t", lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    write_text_atomic(path, buf.getvalue())
