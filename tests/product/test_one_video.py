"""A face from one video: the script readers, the long-form aligner, the utterances, the checks.

The video is made at test time from the committed GRID s1 clips
(:func:`miketalk_lab.bench.joined.join_clips`): no new data.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from miketalk.corpus.clip_sources import decode_clip
from miketalk.corpus.one_video import (
    check_video_inputs,
    face_clips,
    segment_video,
    video_clips,
)
from miketalk.corpus.script import Cue, read_script, text_words
from miketalk.errors import MiketalkError
from miketalk.media.decode import read_media_audio, read_video
from miketalk.media.video import write_mp4
from miketalk_lab.bench.joined import join_clips
from miketalk_lab.bench.one_video import boundary_errors

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data" / "grid_s1"
#: Three training clips then one held-out clip (3 s each).
CLIPS = ["bbaf2n", "lgwg2n", "pric4p", "bbas3a"]
#: Every clip's line, and the joined clips' lines.
_TEXT = dict(line.split(" ", 1) for line in (DATA / "transcripts.txt").read_text().splitlines())
_TRUE = [_TEXT[c] for c in CLIPS]


def join(ids, out):
    return join_clips(
        ids,
        out,
        media=str(DATA / "video" / "{id}.mpg"),
        transcripts=DATA / "transcripts.txt",
        timings=str(DATA / "align" / "{id}.align"),
    )


@pytest.fixture(scope="module")
def joined(tmp_path_factory: pytest.TempPathFactory):
    return join(CLIPS, tmp_path_factory.mktemp("joined"))


def test_transcript_words_are_normalised(tmp_path: Path) -> None:
    path = tmp_path / "t.txt"
    path.write_text("Bin blue, at F-two now!\n\nCafé’s “open”.", encoding="utf-8")
    assert read_script(transcript=path) == [
        Cue(("bin", "blue", "at", "f", "two", "now", "cafe's", "open"))
    ]


def test_srt_and_vtt_cues_lose_markup_speakers_and_sounds(tmp_path: Path) -> None:
    srt = tmp_path / "s.srt"
    srt.write_text(
        "1\n00:00:01,000 --> 00:00:02,500\n<i>JOHN:</i> Hello there\n\n"
        "2\n00:00:03,000 --> 00:00:04,000\n[music]\n\n"
        "3\n00:00:04,000 --> 00:00:05,250\n- Good (laughs) night\n",
        encoding="utf-8",
    )
    vtt = tmp_path / "s.vtt"
    vtt.write_text(
        "WEBVTT\n\n00:00:01.000 --> 00:00:02.500\nJOHN: Hello there\n\n"
        "00:00:04.000 --> 00:00:05.250\n<v Ann>Good night\n",
        encoding="utf-8",
    )
    expected = [Cue(("hello", "there"), 1.0, 2.5), Cue(("good", "night"), 4.0, 5.25)]
    assert read_script(subtitles=srt) == expected
    assert read_script(subtitles=vtt) == expected


@pytest.mark.parametrize(
    ("name", "text", "message"),
    [
        ("s.srt", "1\n00:00:02,000 --> 00:00:01,000\nhi\n", "ends"),
        ("s.txt", "hi", "must be .srt or .vtt"),
        ("s.srt", "1\n00:00:01,000 --> 00:00:02,000\n[music]\n", "has no words"),
    ],
)
def test_bad_subtitles_are_one_line(tmp_path: Path, name: str, text: str, message: str) -> None:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    with pytest.raises(MiketalkError, match=message):
        read_script(subtitles=path)


@pytest.mark.parametrize("kind", ["transcript", "subtitles"])
@pytest.mark.parametrize(
    ("source", "message"),
    [
        ("/dev/zero", "more than 1048576 bytes"),
        ("/dev/urandom", "more than 1048576 bytes"),
        ("big", r"holds 1048577 bytes.*split it"),
        ("nul", "not a text file"),
        ("latin1", "not UTF-8"),
        ("missing", "not found"),
    ],
)
def test_a_script_is_read_as_say_reads_a_text_file(
    tmp_path: Path, kind: str, source: str, message: str, finishes
) -> None:
    """Bounded, as ``say -f``'s text: a device that never ends is refused unread (before:
    /dev/zero was "not found", a huge file read whole)."""
    path = tmp_path / ("s.srt" if kind == "subtitles" else "t.txt")
    if source.startswith("/dev/"):
        path.symlink_to(source)
    elif source == "big":
        path.write_bytes(b"bin " * (1 << 18) + b"a")
    elif source == "nul":
        path.write_bytes(b"bin\0blue")
    elif source == "latin1":
        path.write_bytes("café".encode("latin-1"))
    with pytest.raises(MiketalkError, match=message):
        finishes(lambda: read_script(**{kind: path}))  # a read to the end never returns


def test_a_byte_order_mark_is_not_a_word(tmp_path: Path) -> None:
    path = tmp_path / "s.vtt"
    path.write_text("\ufeffWEBVTT\n\n00:00:00.500 --> 00:00:01.500\nbin blue\n", "utf-8")
    assert read_script(subtitles=path) == [Cue(("bin", "blue"), 0.5, 1.5)]
    path = tmp_path / "t.txt"
    path.write_text("\ufeffbin blue", "utf-8")
    assert read_script(transcript=path) == [Cue(("bin", "blue"))]


def test_one_of_transcript_or_subtitles(tmp_path: Path) -> None:
    with pytest.raises(MiketalkError, match="one of them"):
        read_script()
    assert text_words("...") == []


def test_a_clip_span_is_that_part_of_the_video(joined) -> None:
    frames, _ = read_video(joined.video)
    part, _ = read_video(joined.video, start=3.0, frames=75)
    assert np.array_equal(part, frames[75:150])
    sound = read_media_audio(joined.video)
    assert np.array_equal(
        read_media_audio(joined.video, start=3.0, duration=3.0), sound[48000:96000]
    )


@pytest.fixture(scope="module", params=["transcript", "subtitles"])
def segmented(request, joined, tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("segments") / "segments.json"
    path = joined.transcript if request.param == "transcript" else joined.subtitles
    doc = segment_video(joined.video, out, heldout_seconds=3.0, **{request.param: path})
    return doc, out


def test_words_match_grids_timings(segmented, joined) -> None:
    doc, _ = segmented
    truth = pd.read_csv(joined.words, sep="\t", keep_default_na=False)
    errors = boundary_errors(doc, truth)
    assert doc["unaligned"] == []
    assert len(errors) == 2 * len(truth)
    within = (errors["error_ms"].abs() <= 50 + 1e-6).mean()
    assert within >= 0.85, errors.sort_values("error_ms")


def test_the_held_out_part_is_the_end_of_the_video(segmented, joined) -> None:
    doc, path = segmented
    train, test = video_clips(path, "train"), video_clips(path, "test")
    assert [c.text for c in test] == ["bin blue at s three again"]
    assert len(train) == 3
    assert max(c.start + c.span[1] / c.fps for c in train) <= doc["heldout_from"] + 1e-9
    assert min(c.start for c in test) >= doc["heldout_from"]
    assert face_clips({"media": str(joined.video)}, "test", segments=path) == test


def test_an_utterance_decodes_as_a_clip(segmented) -> None:
    _, path = segmented
    clip = video_clips(path, "train")[1]
    decoded = decode_clip(clip)
    assert len(decoded.frames) == clip.span[1]
    assert [w.word for w in decoded.words] == clip.words
    assert [round(w.start, 6) for w in decoded.words] == [w.start for w in clip.given_words]


def test_a_word_that_is_not_said_is_reported_and_left_out(joined, tmp_path: Path) -> None:
    script = tmp_path / "t.txt"
    text = joined.transcript.read_text()
    script.write_text(text.replace("Lay green with g two now.", "Lay green with g two now seven."))
    doc = segment_video(joined.video, tmp_path / "s.json", transcript=script)
    said = [w for u in doc["utterances"] for w, *_ in u["words"]]
    assert "seven" in {u["word"] for u in doc["unaligned"]}, doc["unaligned"]
    assert "seven" not in said
    assert said == [w for c in read_script(transcript=joined.transcript) for w in c.words]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("Le renard brun saute par-dessus le chien paresseux. Il fait beau aujourd'hui.",
         "another language"),
        ("Where is the station please, I would like a ticket to the city centre tonight. "
         * 3, "transcript is another video's|is the transcript this video's"),
    ],
)  # fmt: skip
def test_a_wrong_transcript_is_one_line(joined, tmp_path: Path, text: str, message: str) -> None:
    script = tmp_path / "t.txt"
    script.write_text(text)
    out = tmp_path / "s.json"
    with pytest.raises(MiketalkError, match=message):
        segment_video(joined.video, out, transcript=script)
    assert not out.exists()


def _video(tmp_path: Path, frames: np.ndarray, audio: np.ndarray) -> Path:
    path = tmp_path / "probe.mp4"
    write_mp4(path, frames, fps=25, audio=audio, rate=16000, crf=18)
    return path


def test_no_speech_and_several_faces_are_one_line(joined, tmp_path: Path) -> None:
    frames, _ = read_video(joined.video, frames=100)
    sound = read_media_audio(joined.video)[:64000]
    silent = _video(tmp_path, frames, np.zeros(64000, np.int16))
    with pytest.raises(MiketalkError, match="has no speech"):
        segment_video(silent, tmp_path / "s.json", transcript=joined.transcript)
    two = _video(tmp_path, np.concatenate([frames, frames], axis=2), sound)
    with pytest.raises(MiketalkError, match="several faces"):
        segment_video(two, tmp_path / "s.json", transcript=joined.transcript)
    t = np.arange(64000) / 16000  # a tune: notes of 0.25 s and rests, no speech
    tune = 8000 * np.sin(2 * np.pi * (220 + 110 * np.floor(t / 0.4) % 330) * t) * (t % 0.4 < 0.25)
    music = _video(tmp_path, frames, tune.astype(np.int16))
    with pytest.raises(MiketalkError, match=r"none of the \d+ words can be aligned"):
        segment_video(music, tmp_path / "s.json", transcript=joined.transcript)
    blank = _video(tmp_path, np.full_like(frames, 90), sound)
    with pytest.raises(MiketalkError, match="no face found"):
        segment_video(blank, tmp_path / "s.json", transcript=joined.transcript)
    assert not (tmp_path / "s.json").exists()


def test_segments_are_byte_identical_run_to_run(joined, tmp_path: Path) -> None:
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    segment_video(joined.video, a, subtitles=joined.subtitles, heldout_seconds=3)
    segment_video(joined.video, b, subtitles=joined.subtitles, heldout_seconds=3)
    assert a.read_bytes() == b.read_bytes()
    assert json.loads(a.read_text())["heldout_from"] == 9.0


def test_a_chunk_span_is_found_by_position_not_by_its_first_start() -> None:
    """Two chunks whose first words start at the same time (overlapping cues, cut apart by
    a word that was not placed): the second chunk's span starts half way from the first
    chunk's last word, not from the audio's start."""
    from miketalk.speech.long_chunks import chunk_span, chunks
    from miketalk.speech.word_timings import WordTiming

    first_pass = [(0, WordTiming("bin", 1.0, 1.4)), (2, WordTiming("blue", 1.0, 1.8))]
    missing = {1}
    groups = chunks(first_pass, missing)
    assert [len(g) for g in groups] == [1, 1]
    assert chunk_span(first_pass, 0, 1, 3.0, missing) == pytest.approx((0.5, 1.2))
    assert chunk_span(first_pass, 1, 1, 3.0, missing) == pytest.approx((1.2, 2.4))


@pytest.fixture(scope="module")
def checked(joined):
    """The joined video read and checked once (its face, its sound): the tests below give it
    other scripts."""
    return check_video_inputs(joined.video, transcript=joined.transcript, heldout_seconds=3.0)


def _segment(checked, tmp_path: Path, lines: list[str]) -> dict:
    """``segment_video`` of the joined video with a transcript of ``lines`` (one per line)."""
    script = tmp_path / "t.txt"
    script.write_text("\n".join(lines) + "\n")
    cues = read_script(transcript=script)
    inputs = replace(checked, cues=cues, lines=tuple(len(text_words(x)) for x in lines))
    return segment_video(
        checked.media, tmp_path / "s.json", transcript=script, heldout_seconds=3.0, checked=inputs
    )


def test_caption_lines_longer_than_the_cut_build_from_what_fits(
    checked, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """Each clip's line with words of other sentences at its edges (a caption line longer
    than the clip cut by it): the build goes on, the extra words are listed with their line,
    the words said are all kept."""
    lines = [
        "Set red. Bin blue at f two now.",
        "Lay green with g two now, bin.",
        "Place red in c four please.",
        "Bin blue at s three again.",
    ]
    doc = _segment(checked, tmp_path, lines)
    assert [(u["line"], u["word"]) for u in doc["unaligned"]] == [
        (1, "set"),
        (1, "red"),
        (2, "bin"),
    ]
    said = [w for u in doc["utterances"] for w, *_ in u["words"]]
    assert said == text_words(" ".join(_TRUE))
    assert doc["fit"]["kept_share"] == pytest.approx(24 / 27, abs=1e-4)
    assert "3 of the 27 words left out" in caplog.text and "lines 1 (2 words), 2 (1)" in caplog.text


def test_a_line_of_another_video_is_left_out(checked, tmp_path: Path) -> None:
    """One line of four is another clip's: its words are listed, the others' kept."""
    other = "Set white by p nine soon."
    doc = _segment(checked, tmp_path, [_TRUE[0], other, *_TRUE[2:]])
    assert [(u["line"], u["word"]) for u in doc["unaligned"]] == [(2, w) for w in text_words(other)]
    assert [u["text"] for u in doc["utterances"]] == [_TRUE[0], *_TRUE[2:]]


@pytest.mark.parametrize(
    ("clips", "message"),
    [
        # 5 of the 24 words (21 %) fit before the long aligner's anchors, refused too
        (["pbwx3a", "pgwe6n", "bgbb2p", "lrblzn"], "none of the 24 words can be aligned"),
        (["bwbg8n", "sgbc7s", "bragzp", "lrblzn"], "none of the 24 words can be aligned"),
    ],
)
def test_another_videos_transcript_is_refused(
    checked, tmp_path: Path, clips: list[str], message: str
) -> None:
    """The lines of four other clips of the same talker (the same words and grammar)."""
    with pytest.raises(MiketalkError, match=message) as refused:
        _segment(checked, tmp_path, [_TEXT[c] for c in clips])
    assert "video's" in str(refused.value) and "\n" not in str(refused.value)
    assert not (tmp_path / "s.json").exists()


def test_with_nothing_held_out_every_utterance_trains(checked, tmp_path: Path) -> None:
    """An utterance that ends after the sound (a video's last frames can outlast it) is a
    training one when nothing is held out, not one of neither split."""
    short = replace(checked, duration=checked.duration - 1.0)
    doc = segment_video(checked.media, tmp_path / "s.json", heldout_seconds=0, checked=short)
    assert doc["utterances"][-1]["end"] > short.duration
    assert {u["split"] for u in doc["utterances"]} == {"train"}
