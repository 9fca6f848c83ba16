"""The spans of words heard without confidence: recorded in the corpus, left out of every fit
of the trained face and of the lip-sync choice's scoring (issue 53)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from test_heard import _training_set

from miketalk.corpus.unsure import UNSURE_TABLE, unsure_frames, write_unsure
from miketalk.draw.trained.gains import amplitude_gain, cv_amplitude_gain
from miketalk.draw.trained.training import TrainingSet
from miketalk.draw.trained.trajectory import Context, fit_regularized, fit_window
from miketalk.visemes import VisemeTable


def _sources(corpus: Path, firsts: dict[str, int]) -> None:
    corpus.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(
        [{"clip": c, "media": "joined.mp4", "first_frame": f, "frames": 50, "fps": 25.0}
         for c, f in firsts.items()]
    ).to_csv(corpus / "sources.tsv", sep="\t", index=False)  # fmt: skip


def test_the_unsure_words_are_recorded_per_clip_and_their_frames_found(tmp_path) -> None:
    corpus = tmp_path / "corpus"
    _sources(corpus, {"u1": 10, "u2.1": 70})  # video seconds 0.4-2.4 and 2.8-4.8
    segments = tmp_path / "segments.json"
    segments.write_text(json.dumps({"not_confident": [
        {"word": "bin", "start": 0.0, "end": 0.6, "probability": 0.2},  # before u1 and into it
        {"word": "at", "start": 3.0, "end": 3.06, "probability": 0.4},
        {"word": "lay", "start": 2.4, "end": 2.8, "probability": 0.3},  # between the clips
    ]}))  # fmt: skip
    assert write_unsure(corpus, segments) == 2
    spans = pd.read_csv(corpus / UNSURE_TABLE, sep="\t", dtype={"clip": str})
    assert spans["clip"].tolist() == ["u1", "u2.1"] and spans["word"].tolist() == ["bin", "at"]
    assert np.allclose(spans[["clip_start", "clip_end"]], [[0.0, 0.2], [0.2, 0.26]])
    clip = np.array([0] * 7 + [1] * 9)
    clip_frame = np.r_[np.arange(7), np.arange(9)]
    out = unsure_frames(corpus, ("u1", "u2.1"), clip, clip_frame, 25.0)
    # u1's frames 0-4 (0-0.2 s; frame 5 starts at the span's end); u2.1's 5-6 (0.20-0.28 s)
    assert np.flatnonzero(out).tolist() == [0, 1, 2, 3, 4, 7 + 5, 7 + 6]
    segments.write_text(json.dumps({"words_from": "given"}))  # a transcript: none
    assert write_unsure(corpus, segments) == 0
    assert not unsure_frames(corpus, ("u1", "u2.1"), clip, clip_frame, 25.0).any()
    (corpus / UNSURE_TABLE).unlink()  # a corpus of clips has no table: none
    assert not unsure_frames(corpus, ("u1", "u2.1"), clip, clip_frame, 25.0).any()


def _kept_only(data: TrainingSet) -> TrainingSet:
    """The frames ``data`` keeps, the others cut out (what a fit without them sees)."""
    return TrainingSet(
        data.phones,
        tuple(data.fitted_rows(data.times)),
        tuple(data.fitted_rows(data.coords)),
        data.recordings,
    )


def test_the_fits_learn_nothing_from_the_frames_left_out() -> None:
    """Frames whose description is garbage (speech labelled as a pause, say) change every
    trajectory's fit and gain when fitted; left out, the fit is the one of the others alone,
    and the cross-validated predictions still cover every frame."""
    data = _training_set(10, seed=4)
    rng = np.random.default_rng(5)
    kept = tuple(rng.random(len(c)) > 0.15 for c in data.coords)
    spoilt = tuple(np.where(k[:, None], c, 40.0) for c, k in zip(data.coords, kept, strict=True))
    marked = TrainingSet(data.phones, data.times, spoilt, data.recordings, kept)
    alone = _kept_only(marked)
    table = VisemeTable()
    context = Context.of(data.phones, table)
    for heard in (0, 4):
        held: dict = {}
        left_out, report = fit_window(marked, context, table, half=3, heard=heard,
                                      predictions=held)  # fmt: skip
        cut, cut_report = fit_window(alone, context, table, half=3, heard=heard)
        fitted_all, _ = fit_window(
            TrainingSet(data.phones, data.times, spoilt, data.recordings), context, table,
            half=3, heard=heard,
        )  # fmt: skip
        assert np.allclose(left_out.weights, cut.weights) and left_out.ridge == cut.ridge
        assert report["cv_r2"] == cut_report["cv_r2"]
        assert not np.allclose(left_out.weights, fitted_all.weights)
        assert [len(held[i]) for i in range(len(kept))] == [len(k) for k in kept]
        assert amplitude_gain(left_out, marked, table) == amplitude_gain(cut, alone, table)
        assert cv_amplitude_gain(held, marked) == cv_amplitude_gain(
            {i: p[k] for (i, p), k in zip(sorted(held.items()), kept, strict=True)}, alone
        )
    smooth, _ = fit_regularized(marked, context, table)
    smooth_cut, _ = fit_regularized(alone, context, table)
    assert np.allclose(smooth.phone_mean, smooth_cut.phone_mean)
    assert smooth.smoothness == smooth_cut.smoothness


def test_a_build_from_recognized_words_leaves_their_frames_out(tmp_path) -> None:
    """The corpus's unsure spans reach the trained face's fit through the corpus folder
    (``FitSettings.leave_unsure``, the default), and the choice's scoring."""
    from test_trained import _synthetic_corpus

    from miketalk.draw.trained.build import fitted_face
    from miketalk.draw.trained.mouths import measure_frames
    from miketalk.draw.trained.selection import SelectionSettings
    from miketalk.draw.trained.training import FitSettings, training_set

    corpus = _synthetic_corpus(tmp_path, n_clips=5)
    frames = measure_frames(corpus, components=6)
    (corpus / UNSURE_TABLE).write_text("clip\tword\tclip_start\tclip_end\nc1\tbin\t0.3\t0.7\n")
    data = training_set(corpus, frames)
    assert data.kept is not None  # c1's frames 7-17 (0.28-0.72 s)
    assert [int((~k).sum()) for k in data.kept] == [0, 11, 0, 0, 0]
    assert training_set(corpus, frames, leave_unsure=False).kept is None
    settings = {"selection": SelectionSettings(), "table": VisemeTable()}
    face = fitted_face(frames, corpus, **settings)
    before = fitted_face(frames, corpus, fitting=FitSettings(leave_unsure=False), **settings)
    assert face.report["fit"]["frames_left_out"] == 11
    assert before.report["fit"]["frames_left_out"] == 0
    for name in ("window", "heard"):
        assert not np.allclose(face.trajectories[name].weights,
                               before.trajectories[name].weights)  # fmt: skip
    (corpus / UNSURE_TABLE).unlink()
    again = fitted_face(frames, corpus, **settings)
    assert again.report["fit"]["frames_left_out"] == 0
    assert np.array_equal(again.trajectories["heard"].weights, before.trajectories["heard"].weights)


def test_a_segmentation_with_no_unsure_word_needs_no_sources_table(tmp_path) -> None:
    """A script-given build (no unsure words) writes an empty table without reading the
    corpus's ``sources.tsv``."""
    corpus = tmp_path / "corpus"
    corpus.mkdir()
    segments = tmp_path / "segments.json"
    segments.write_text(json.dumps({"words_from": "given", "fps": 25.0, "utterances": []}))
    assert write_unsure(corpus, segments) == 0
    assert (corpus / UNSURE_TABLE).read_text() == "clip\tword\tclip_start\tclip_end\n"


def test_a_corpus_of_the_videos_own_frames_says_where_its_clips_are(s1_built) -> None:
    """A ``--frame full`` build of one video writes ``sources.tsv`` too: each clip's span in the
    video (a clip cut in pieces, ``u0003.1``, placed by its own), so unsure spans land in
    pieces as they do in a face crop's corpus."""
    corpus = s1_built.parent / "corpus"
    sources = pd.read_csv(corpus / "sources.tsv", sep="\t", dtype={"clip": str})
    clips = pd.read_csv(corpus / "clips.tsv", sep="\t", dtype={"clip": str})
    assert sources["clip"].tolist() == clips["clip"].tolist()
    assert sources["frames"].tolist() == clips["frames"].tolist()
    segments = json.loads((s1_built / "build" / "segments.json").read_text())
    first = {u["id"]: u["first_frame"] for u in segments["utterances"]}
    for c in sources.itertuples():  # a piece starts within its utterance
        utterance = c.clip.split(".")[0]
        assert first[utterance] <= c.first_frame
    assert (sources["fps"] == segments["fps"]).all()
