"""A person's corpus from one video and its transcript or subtitles: utterances cut at pauses.

:func:`segment_video` is the first stage of a face whose corpus is one video
(``corpus: {source: video, media: ..., transcript: ... | subtitles: ...}``):

1. the transcript or subtitles are read (:mod:`miketalk.corpus.script`), and a
   transcript whose words the aligner's English dictionary mostly lacks is
   refused (another language);
2. the video's sound is aligned in pieces (:func:`miketalk.speech.long_align.align_long`),
   keeping only the words that fit the sound, in stretches of several
   (:mod:`miketalk.corpus.script_fit`); the others are reported (``unaligned`` in
   the file, each with its line and why, and the log) and their audio left out. A
   script of which little fits and that explains little of the speech is taken for
   another video's and refused;
3. the second pass's chunks, cut at pauses, are the utterances: each is a span
   of whole frames of the video with its words (:class:`~miketalk.corpus.clip_sources.Clip`
   with ``span``), so the rest is the clip corpus's own code: stabilization,
   skipped-frame reporting, phones;
4. the last ``heldout_seconds`` of the video are held out: an utterance that
   starts there is a test utterance, one that ends before it a training one,
   one across the boundary is used for neither (never interleaved).

It writes ``segments.json``; :func:`video_clips` reads the training or test
utterances back as clips.
"""

from __future__ import annotations

import json
import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from miketalk import defaults
from miketalk.corpus.clip_sources import RATE, Clip
from miketalk.corpus.script import read_script
from miketalk.errors import MiketalkError
from miketalk.media.atomic import write_text_atomic
from miketalk.speech.word_timings import WordTiming

if TYPE_CHECKING:
    from miketalk.corpus.heard_script import HeardScript

log = logging.getLogger(__name__)

#: The stage's file.
SEGMENTS = "segments.json"

#: Below this share of a transcript's words in the aligner's English dictionary,
#: the transcript is taken for another language.
MIN_ENGLISH_SHARE = 0.6

#: A face's corpus needs at least this many of the 16 viseme classes spoken in its
#: training part; the others borrow an image (data/viseme_fallbacks.tsv).
MIN_VISEME_CLASSES = 10

#: The least voiced audio (s) a video must have to be aligned at all.
MIN_VOICED_SECONDS = 1.0


def segment_video(
    media: str | Path,
    out: str | Path,
    *,
    transcript: str | Path | None = None,
    subtitles: str | Path | None = None,
    heldout_seconds: float = defaults.HELDOUT_SECONDS,
    checked: VideoInputs | None = None,
) -> dict:
    """Align a video's words and cut it into utterances; write ``segments.json`` (``out``).

    Parameters
    ----------
    media : path
        The video (with sound).
    out : path
        The JSON file to write (atomically).
    transcript, subtitles : path
        Its plain transcript, or its ``.srt`` / ``.vtt`` subtitles (one of them, or neither:
        its words are then recognized, :mod:`miketalk.corpus.heard_script`).
    heldout_seconds : float
        The last seconds held out for the test (0: none).
    checked : VideoInputs, optional
        What :func:`check_video_inputs` gave for these inputs (not read again).

    Returns
    -------
    dict
        What the file holds.

    Raises
    ------
    MiketalkError
        One line for: a missing or unreadable video, no sound or no speech, a
        transcript in another language or of another video
        (:func:`miketalk.corpus.script_fit.judge`), nothing left to train on.
    """
    from functools import partial

    from miketalk.corpus.script_fit import (
        MIN_STRETCH,
        judge,
        line_of,
        measure_fit,
        trusted,
        where,
    )
    from miketalk.speech.align.phones import FIT_LIMIT
    from miketalk.speech.long_align import align_long
    from miketalk.workers import run_in_child

    video = checked or check_video_inputs(
        media, transcript=transcript, subtitles=subtitles, heldout_seconds=heldout_seconds
    )
    media, cues, samples, fps = video.media, video.cues, video.samples, video.fps
    duration, voiced = video.duration, video.voiced_seconds
    # in a child process: the aligner and its recogniser hold the interpreter for seconds
    # at a time, and Ctrl-C or SIGTERM must stop the build at once (run_in_child)
    found = run_in_child(partial(align_long, fit_limit=FIT_LIMIT), samples, RATE, cues)
    # recognized words are timed by the recognizer: a short stretch of them is where it heard it
    found = trusted(found, MIN_STRETCH if video.heard is None else 1)
    total = sum(len(c.words) for c in cues)
    lines = video.lines or tuple(len(c.words) for c in cues)
    fit = measure_fit(found, lines, samples, RATE)
    refusal = judge(fit, media.name)
    if refusal and (video.heard is None or fit.kept == 0):
        raise MiketalkError(refusal)
    if refusal:  # the words came from the sound itself: those that do not fit are left out
        log.warning(
            "%s: only %d of its %d recognized words fit its sound in stretches; the model is "
            "built from them", media.name, fit.kept, fit.words,
        )  # fmt: skip
    if found.unaligned:
        log.warning(
            "%d of the %d words left out, and their audio: they do not fit the sound (%s; "
            "each listed in %s with why)", len(found.unaligned), total,
            where(found.unaligned, lines), Path(out).name,
        )  # fmt: skip
    boundary = duration - heldout_seconds
    line = line_of(lines)
    utterances, k = [], 0
    for number, (lo, hi, n) in enumerate(found.chunks, 1):
        words = [w for _, w in found.words[k : k + n]]
        k += n
        a = min(math.ceil(lo * fps - 1e-6), math.floor(words[0].start * fps + 1e-6))
        b = max(math.floor(hi * fps + 1e-6), math.ceil(words[-1].end * fps - 1e-6))
        # nothing held out: all is training, also an utterance whose last frame outlasts
        # the sound (a video's frames can end a little after its sound)
        ends_before = heldout_seconds <= 0 or b / fps <= boundary + 1e-9
        split = "train" if ends_before else "test" if a / fps >= boundary else None
        utterances.append(
            {
                "id": f"u{number:04d}",
                "first_frame": a,
                "frames": b - a,
                "start": round(a / fps, 6),
                "end": round(b / fps, 6),
                "split": split or "neither",
                "text": " ".join(w.word for w in words),
                "words": [
                    [w.word, round(w.start - a / fps, 6), round(w.end - a / fps, 6)] for w in words
                ],
            }
        )
    if not any(u["split"] == "train" for u in utterances):
        raise MiketalkError(
            f"no utterance of {media.name} is left to train on before the held-out "
            f"last {heldout_seconds:g} s"
        )
    doc = {
        "media": str(media),
        "fps": fps,
        "size": list(video.size),
        "duration": round(duration, 6),
        "heldout_from": round(boundary, 6),
        "words": total,
        "voiced_seconds": round(voiced, 3),
        "utterances": utterances,
        "fit": {
            "kept_share": round(fit.kept_share, 4),
            "explained_share": round(fit.explained_share, 4),
            "left_out_at_line_edges": fit.at_edges,
        },
        "unaligned": [
            {"index": u.index, "line": int(line[u.index]) + 1, "word": u.word, "why": u.why}
            for u in found.unaligned
        ],
    } | (video.heard.record() if video.heard is not None else {"words_from": "given"})
    write_text_atomic(Path(out), json.dumps(doc, indent=1) + "\n")
    return doc


@dataclass(frozen=True)
class VideoInputs:
    """A video and its script, checked: what :func:`segment_video` aligns."""

    media: Path
    cues: list
    samples: np.ndarray
    fps: float
    size: tuple[int, int]
    duration: float
    voiced_seconds: float
    #: How many words each line of the script has: a plain transcript's lines, or the cues.
    lines: tuple[int, ...] = ()
    #: With no transcript and no subtitles: the words recognized (the cues are theirs).
    heard: HeardScript | None = None


def check_video_inputs(
    media: str | Path,
    *,
    transcript: str | Path | None = None,
    subtitles: str | Path | None = None,
    heldout_seconds: float = defaults.HELDOUT_SECONDS,
) -> VideoInputs:
    """Read and check a video and its script before any work (see :func:`segment_video`).

    Raises
    ------
    MiketalkError
        One line: a missing or unreadable video or script, another language, no
        face or several, no speech, everything held out.
    """
    from miketalk.corpus.script_fit import check_script_length
    from miketalk.media.decode import read_media_audio, read_video
    from miketalk.speech.coverage import HOP_SECONDS, voiced_frames

    media = Path(media)
    if not media.is_file():
        raise MiketalkError(f"video not found: {media}")
    if heldout_seconds < 0:
        raise MiketalkError(f"heldout_seconds must be >= 0, got {heldout_seconds}")
    recognize = transcript is None and subtitles is None
    cues = [] if recognize else read_script(transcript=transcript, subtitles=subtitles)
    if not recognize:
        _check_english(cues)
    first, fps = read_video(media, frames=1)
    samples = read_media_audio(media, rate=RATE)
    duration = len(samples) / RATE
    check_script_length(sum(len(c.words) for c in cues), duration, media.name)
    if heldout_seconds >= duration:
        raise MiketalkError(
            f"heldout_seconds ({heldout_seconds:g}) holds out all of the {duration:.1f} s video"
        )
    _check_face(media, duration)
    voiced = float(voiced_frames(samples, RATE).sum() * HOP_SECONDS)
    if voiced < MIN_VOICED_SECONDS:
        raise MiketalkError(f"{media} has no speech ({voiced:.1f} s of voiced sound)")
    size = (int(first.shape[1]), int(first.shape[2]))
    lines = _lines(transcript, cues) if transcript is not None else ()
    heard = None
    if recognize:  # here, not in a forked child (miketalk.talk.recorded.align_recording)
        from miketalk.corpus.heard_script import heard_script

        heard = heard_script(samples, RATE, media.name)
        cues = heard.cues
    return VideoInputs(media, cues, samples, fps, size, duration, voiced, lines, heard)


def _lines(transcript: str | Path, cues) -> tuple[int, ...]:
    """How many words each line of a plain transcript has (its empty lines left out): where
    its words that do not fit are (one line for all when its lines split a word)."""
    from miketalk.corpus.script import script_text, text_words

    text = script_text(transcript)
    counts = tuple(n for n in (len(text_words(line)) for line in text.splitlines()) if n)
    total = sum(len(c.words) for c in cues)
    return counts if sum(counts) == total else (total,)


def video_clips(segments: str | Path, split: str, *, media: str | Path | None = None) -> list[Clip]:
    """The utterances of ``split`` (``train`` or ``test``) in ``segments.json``, as clips.

    ``media`` (default: the file named in ``segments.json``) is where they are cut from.
    """
    doc = json.loads(Path(segments).read_text(encoding="utf-8"))
    return [_utterance_clip(doc, u, media) for u in doc["utterances"] if u["split"] == split]


def _utterance_clip(doc: dict, utterance: dict, media: str | Path | None) -> Clip:
    """An utterance of ``segments.json`` as a clip of ``media`` (default: the file it names)."""
    return Clip(
        utterance["id"],
        Path(media or doc["media"]),
        utterance["text"],
        span=(utterance["first_frame"], utterance["frames"]),
        fps=float(doc["fps"]),
        given_words=tuple(WordTiming(w, a, b) for w, a, b in utterance["words"]),
        sound_lag=float(doc.get("sound_lag_s", 0.0)),
    )


def _check_face(media: Path, duration: float) -> None:
    """Refuse a video that does not show one face (:mod:`miketalk.stabilize.faces`)."""
    from miketalk.media.decode import read_video
    from miketalk.stabilize.faces import SAMPLES, check_one_face

    times = (np.arange(SAMPLES) + 0.5) * duration / SAMPLES
    frames = [read_video(media, start=float(t), frames=1)[0][0] for t in times]
    check_one_face(frames, source=media.name)


#: The most common words of English and of the languages a transcript is most often in
#: instead (a word on two lists counts for both).
_COMMON = {
    "English": "the and of to is that it was for you with this have not are but they be he "
    "she what there his her we would could should from which",
    "French": "le la les et est une des du pas que qui dans pour sur au avec je vous nous il "
    "elle ce mais ou sont",
    "Spanish": "el los las y es una del que en por para con se lo su al pero como muy",
    "German": "der die das und ist ein eine nicht mit den dem zu ich sie es auf für auch",
    "Italian": "il di che è per una sono della non gli con del mi ti ci anche",
    "Portuguese": "os as um uma não com para que por mais como mas ao dos das",
    "Dutch": "de het een en van niet met op zijn voor ik je dat wat",
}
_COMMON_WORDS = {lang: frozenset(common.split()) for lang, common in _COMMON.items()}


def _check_english(cues) -> None:
    """Refuse a script in another language: its common words are another language's, or
    the aligner's English dictionary lacks most of its words."""
    from miketalk.speech.align.decoder import _LOCK, _shared_aligner

    tokens = [w for c in cues for w in c.words]
    counts = {lang: sum(w in common for w in tokens) for lang, common in _COMMON_WORDS.items()}
    likely = max(counts, key=counts.get)
    if likely != "English" and counts[likely] > max(2, 2 * counts["English"]):
        raise MiketalkError(
            f"the transcript looks like {likely}, another language ({counts[likely]} of its "
            f"{len(tokens)} words are common {likely} words): the aligner is English only"
        )
    words = sorted(set(tokens))
    with _LOCK:
        aligner = _shared_aligner()
        known = sum(aligner.in_dictionary(w) for w in words)
        said = [aligner.decoder.lookup_word(w) for w in words]
    if known < MIN_ENGLISH_SHARE * len(words):
        raise MiketalkError(
            f"only {known} of the {len(words)} different words of the transcript are English "
            "words the aligner knows: is it in another language? (the aligner is English only)"
        )
    _check_classes_said(said, len(tokens))


def _check_classes_said(pronunciations, words: int) -> None:
    """Refuse, before any work, a script whose words (by the dictionary) cannot show
    :data:`MIN_VISEME_CLASSES` viseme classes even if all of it is aligned."""
    from miketalk.visemes import VisemeTable

    phones = (p.lower().rstrip("012") for said in pronunciations if said for p in said.split())
    classes = VisemeTable().spoken_visemes(phones)
    if len(classes) < MIN_VISEME_CLASSES:
        raise MiketalkError(
            f"too little speech for the viseme classes: the script's {words} words show "
            f"{len(classes)} of the classes, at least {MIN_VISEME_CLASSES} are needed: give a "
            "longer video"
        )


def face_clips(corpus: dict, split: str, *, segments: str | Path | None = None) -> list[Clip]:
    """A face's clips of ``split``: its utterances (``segments.json``) or its listed clips.

    ``corpus`` is the face's corpus settings (paths absolute); ``segments`` the
    segment stage's file of a face from one video.
    """
    from miketalk.corpus.clip_sources import clip_sources

    if segments is not None:
        return video_clips(segments, split, media=corpus["media"])
    return clip_sources(
        corpus[split],
        media=corpus["media"],
        transcripts=corpus["transcripts"],
        timings=corpus["timings"],
    )


def utterance_clip(segments: str | Path, clip: str, *, media: str | Path | None = None) -> Clip:
    """Utterance ``clip`` of ``segments.json`` as a clip: where the corpus cut it."""
    doc = json.loads(Path(segments).read_text(encoding="utf-8"))
    for u in doc["utterances"]:
        if u["id"] == clip:
            return _utterance_clip(doc, u, media)
    raise MiketalkError(f"{segments}: no utterance {clip}")
