"""The trained face (miketalk.draw.trained): trajectories, selection, compositing, end to end."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from miketalk.draw.trained import fit_trained, read_trained
from miketalk.draw.trained.draw import render_trained
from miketalk.draw.trained.mouths import MouthFrames, feather_mask
from miketalk.draw.trained.selection import PatchCompositor, SelectionSettings, select
from miketalk.draw.trained.trajectory import PAUSE_BINS, pause_features, ridge, smooth_targets
from miketalk.errors import MiketalkError
from miketalk.lipsync.timeline import plan
from miketalk.model.parts import trained_trajectories
from miketalk.speech.acoustic import RATE, Recording
from miketalk.speech.types import Phone
from miketalk.visemes import default_table
from miketalk_lab.evaluation.dub_heldout import dub_renderer

#: Mouth opening (pixels) of each phone of the synthetic speaker.
OPENING = {"pau": 1, "m": 0, "p": 0, "aa": 9, "iy": 3, "s": 2, "uw": 5}
FPS = 25.0
SIZE = (120, 160)  # (H, W)
MOUTH_BOX = (70, 70, 20, 6)


def test_smooth_targets_is_the_least_cost_trajectory() -> None:
    rng = np.random.default_rng(0)
    n, dims = 30, 2
    mean, var = rng.normal(size=(n, dims)), rng.uniform(0.5, 2.0, size=(n, dims))
    scale, times = np.array([1.0, 2.0]), np.arange(n) / 25.0
    out = smooth_targets(mean, var, scale, 1e-6, times)
    d2 = np.diff(np.eye(n), 2, axis=0) * 25.0**2  # second differences in 1/s^2
    for d in range(dims):
        lam = 1e-6 / scale[d]
        a = np.diag(1 / var[:, d]) + lam * d2.T @ d2
        assert np.allclose(out[:, d], np.linalg.solve(a, mean[:, d] / var[:, d]), atol=1e-8)
    assert np.allclose(smooth_targets(mean, var, scale, 0.0, times), mean)
    smooth = smooth_targets(mean, var, scale, 1e-3, times)
    assert np.abs(np.diff(smooth, 2, axis=0)).max() < np.abs(np.diff(out, 2, axis=0)).max()


def test_pause_features_say_how_far_the_speech_is_in_a_silence_only() -> None:
    phones = (Phone("pau", 0.0, 0.5), Phone("m", 0.5, 0.6), Phone("aa", 0.6, 0.8),
              Phone("pau", 0.8, 2.0))  # fmt: skip
    times = np.array([0.0, 0.45, 0.55, 0.7, 0.85, 1.9])
    x = pause_features(phones, times, default_table())
    n_bins = len(PAUSE_BINS) + 1
    assert x.shape == (6, 2 * n_bins)
    assert (x[[2, 3]] == 0).all()  # in speech
    assert x[0, np.searchsorted(PAUSE_BINS, 0.5)] == 1 and x[0, n_bins:].sum() == 0  # 0.5 s ahead
    assert x[1, np.searchsorted(PAUSE_BINS, 0.05)] == 1
    assert x[4, n_bins + np.searchsorted(PAUSE_BINS, 0.05)] == 1 and x[4, :n_bins].sum() == 0
    assert x[5, n_bins + n_bins - 1] == 1  # more than 1 s after: the last bin


def test_ridge_recovers_linear_weights() -> None:
    rng = np.random.default_rng(1)
    x = rng.normal(size=(400, 5))
    w = rng.normal(size=(5, 3))
    weights, intercept = ridge(x, x @ w + 2.0, 1e-6)
    assert np.allclose(weights, w, atol=1e-6) and np.allclose(intercept, 2.0, atol=1e-6)


def _frames(coords: np.ndarray, clips: np.ndarray) -> MouthFrames:
    n = len(coords)
    clip_frame = np.concatenate([np.arange((clips == c).sum()) for c in np.unique(clips)])
    return MouthFrames(
        coords=coords, patches=np.zeros((n, 30, 30, 3), np.uint8), border=np.zeros((n, 3)),
        clip=clips, clip_frame=clip_frame, clip_ids=tuple(map(str, np.unique(clips))),
        mean=np.zeros(1), components=np.zeros((coords.shape[1], 1)),
        variance=coords.var(axis=0), region=(0, 0, 1, 1), patch=(0, 0, 30, 30), fps=FPS,
    )  # fmt: skip


def test_a_join_is_morphed_half_way_where_a_cross_fade_shows_both() -> None:
    """Two frames about a jump, a nearly closed and an open mouth, blended half and half:
    the morph opens the dark mouth part of the way; the cross-fade keeps only the closed
    one dark, inside a pale ghost of the open one."""
    patches = np.full((2, 60, 60, 3), 200, np.uint8)
    for k, half_height in enumerate((3, 15)):
        cv2.ellipse(patches[k], (30, 30), (18, half_height), 0, 0, 360, (20, 20, 20), -1)
    texture = np.random.default_rng(5).integers(150, 250, (60, 60, 1)).astype(np.uint8)
    patches = np.minimum(patches, texture)  # texture for the flow to follow
    frames = _frames(np.zeros((2, 1)), np.array([0, 1]))
    frames = MouthFrames(**{**frames.__dict__, "patches": patches,
                            "border": np.full((2, 3), 200.0), "patch": (0, 0, 60, 60)})  # fmt: skip
    face = np.full((60, 60, 3), 200, np.uint8)
    row = ((0, 0.5), (1, 0.5))
    # the patches in the face's light already: the joins alone (a flat face has no light for
    # the default's CIELAB transfer to learn: test_patch_light)
    morphed = PatchCompositor(frames, face, joins="morph", light="border").patch(row)[..., 0]
    dissolved = PatchCompositor(frames, face, joins="dissolve", light="border").patch(row)[..., 0]
    closed, opened = 7, 31  # dark rows down the middle column
    assert (dissolved[:, 30] < 60).sum() == closed
    assert closed + 4 <= (morphed[:, 30] < 60).sum() <= opened - 4
    ghost = lambda image: ((image > 60) & (image < 140))[10:50, 20:40].sum()  # noqa: E731
    assert ghost(morphed) < 0.8 * ghost(dissolved)
    one = PatchCompositor(frames, face, joins="morph").patch(((1, 1.0),))
    assert np.array_equal(one, PatchCompositor(frames, face, joins="dissolve").patch(((1, 1.0),)))
    with pytest.raises(MiketalkError, match="joins must be one of"):
        PatchCompositor(frames, face, joins="wipe")


def test_selection_follows_a_recorded_run_and_prefers_it_to_jumps() -> None:
    rng = np.random.default_rng(2)
    coords = rng.normal(size=(200, 4))
    frames = _frames(coords, np.repeat([0, 1], 100))
    path = select(frames, coords[20:50], SelectionSettings())
    assert path.tolist() == list(range(20, 50))
    # a noisy target: joins keep the recording's own runs
    noisy = coords[120:160] + rng.normal(scale=0.3, size=(40, 4))
    chosen = select(frames, noisy, SelectionSettings(join=1.0))
    steps = np.diff(chosen)
    assert np.mean((steps >= 0) & (steps <= 2)) > 0.8


def test_the_viseme_cost_prefers_a_frame_of_the_output_frames_viseme() -> None:
    # two recordings of the same shapes; the second one's frames were another viseme
    rng = np.random.default_rng(5)
    shapes = rng.normal(size=(30, 4))
    coords = np.concatenate([shapes, shapes + 0.01])
    frames = _frames(coords, np.repeat([0, 1], 30))
    recorded = np.repeat([3, 7], 30)
    target = shapes[5:25] + 0.005  # as near one as the other
    shown = np.full(20, 7)
    cost = SelectionSettings(viseme=5.0)
    assert (select(frames, target, cost, visemes=(shown, recorded)) >= 30).all()
    assert (select(frames, target, cost, visemes=(shown - 4, recorded)) < 30).all()
    # no cost (a face fitted before it): the shapes alone choose, whatever the visemes say
    none = SelectionSettings(viseme=0.0)
    plain = select(frames, target, none)
    assert np.array_equal(select(frames, target, none, visemes=(shown, recorded)), plain)
    # a shape far from the target is not taken for its viseme
    far = coords.copy()
    far[30:] += 3.0
    frames = _frames(far, np.repeat([0, 1], 30))
    assert (select(frames, target, cost, visemes=(shown, recorded)) < 30).all()


def test_feathered_composite_has_no_seam() -> None:
    mask = feather_mask(40, 50)
    assert mask[20, 25] > 0.98 and mask[0].max() < 2e-3 and mask[:, 0].max() < 2e-3
    face = np.full((60, 70, 3), 100, np.uint8)
    patches = np.full((1, 40, 50, 3), 160, np.uint8)
    patches[0, 15:25, 15:35] = 20  # a dark mouth inside
    frames = _frames(np.zeros((1, 1)), np.zeros(1, int))
    frames = MouthFrames(**{**frames.__dict__, "patches": patches, "border": np.full((1, 3), 160.0),
                            "patch": (10, 10, 50, 40)})  # fmt: skip
    out = PatchCompositor(frames, face, light="border").frame(((0, 1.0),))
    # light matched by the border's offset: the patch's 160 becomes the face's 100 at the
    # border and inside (the default's CIELAB transfer: test_patch_light)
    assert np.abs(out.astype(int) - 100)[:, :, 0][out[..., 0] > 50].max() <= 1
    assert out[30, 35, 0] < 50  # the mouth is drawn
    assert (out[:10] == 100).all() and (out[:, :10] == 100).all()


def _synthetic_corpus(root: Path, n_clips: int = 8, seed: int = 3) -> Path:
    """A tiny corpus folder as the corpus stage writes it: a dark mouth that opens by phone."""
    from miketalk.corpus.folder import frame_path, words_doc
    from miketalk.media.audio import write_wav
    from miketalk.media.images import write_png

    rng = np.random.default_rng(seed)
    corpus = root / "corpus"
    (corpus / "frames").mkdir(parents=True)
    texture = cv2.GaussianBlur(rng.uniform(90, 200, size=SIZE).astype(np.float32), (0, 0), 3)
    clips, phones_rows, k = [], [], 0
    for c in range(n_clips):
        phones = _sentence(rng)
        n = round(phones[-1].end * FPS)
        for j in range(n):
            write_png(frame_path(corpus / "frames", k + j), face_with(texture, phones, j / FPS))
        clips.append(f"c{c}\t{k}\t{n}\t{k / FPS:.6f}\t{n / FPS:.6f}\tx")
        phones_rows += [
            f"c{c}\t{i}\t{p.name}\t{p.start + k / FPS:.6f}\t{p.end + k / FPS:.6f}\t"
            f"{p.start:.6f}\t{p.end:.6f}"
            for i, p in enumerate(phones)
        ]
        k += n
    (corpus / "clips.tsv").write_text(
        "clip\tfirst_frame\tframes\tstart\tduration\ttext\n" + "\n".join(clips) + "\n"
    )
    (corpus / "phones.tsv").write_text(
        "clip\tindex\tphone\tstart\tend\tclip_start\tclip_end\n" + "\n".join(phones_rows) + "\n"
    )
    regions = {"mouth_box": list(MOUTH_BOX), "size": list(SIZE), "clips": n_clips}
    (corpus / "regions.json").write_text(json.dumps(regions))
    (corpus / "words.json").write_text(words_doc(fps=FPS, size=list(SIZE), rate=16000, words=[]))
    write_wav(corpus / "audio.wav", np.zeros(1600, np.int16), 16000)
    return corpus


def _sentence(rng: np.random.Generator) -> tuple[Phone, ...]:
    names = ["pau", *rng.choice(["m", "p", "aa", "iy", "s", "uw"], size=10).tolist(), "pau"]
    t, out = 0.0, []
    for name in names:
        d = 0.3 if name == "pau" else float(rng.uniform(0.08, 0.2))
        out.append(Phone(name, t, t + d))
        t += d
    return tuple(out)


def face_with(texture: np.ndarray, phones: tuple[Phone, ...], t: float) -> np.ndarray:
    """The synthetic face at ``t``: a dark ellipse of the phone's opening, eased between phones."""
    mids = np.array([(p.start + p.end) / 2 for p in phones])
    opening = float(np.interp(t, mids, [OPENING[p.name] for p in phones]))
    image = texture.copy()
    x, y, w, h = MOUTH_BOX
    cv2.ellipse(image, (x + w // 2, y + h // 2), (9, round(opening) // 2 + 1), 0, 0, 360,
                30.0, -1)  # fmt: skip
    return np.repeat(np.clip(image, 0, 255).astype(np.uint8)[..., None], 3, axis=2)


def test_trained_face_learns_and_draws_a_new_sentence(tmp_path: Path) -> None:
    corpus = _synthetic_corpus(tmp_path)
    model = tmp_path / "model"
    doc = fit_trained(corpus, model / "trained", components=6)
    assert doc["default"] == "window" and doc["fit"]["clips"] == 8
    again = fit_trained(corpus, tmp_path / "again" / "trained", components=6)
    a = np.load(model / "trained" / "trajectory.npz")
    b = np.load(tmp_path / "again" / "trained" / "trajectory.npz")
    assert all(np.array_equal(a[k], b[k]) for k in a.files) and again["fit"] == doc["fit"]
    trained = read_trained(model / "trained")
    rng = np.random.default_rng(99)
    texture = cv2.GaussianBlur(rng.uniform(90, 200, size=SIZE).astype(np.float32), (0, 0), 3)
    phones = _sentence(np.random.default_rng(7))
    timeline = plan(phones, default_table(), fps=30.0, duration=phones[-1].end)
    face = SimpleNamespace(directory=model, image=lambda _: face_with(texture, phones, 0.0))
    frames = np.stack(list(render_trained(face, timeline, trained=trained)))
    assert frames.shape == (len(timeline.frames), *SIZE, 3)
    x, y, w, h = MOUTH_BOX
    dark = (frames[:, y - 8 : y + h + 8, x : x + w, 0] < 60).sum(axis=(1, 2))
    truth = [
        (face_with(texture, phones, f.time)[y - 8 : y + h + 8, x : x + w, 0] < 60).sum()
        for f in timeline.frames
    ]
    assert np.corrcoef(dark, truth)[0, 1] > 0.8


def test_a_trained_face_fitted_before_the_cross_validated_gain_still_draws(
    tmp_path: Path,
) -> None:
    """A ``trained.json`` written before ``cv_gain`` and ``amplitude_gain_cv`` existed is
    read with the fitted gain it was made with, and draws the same target as then."""
    import json

    corpus = _synthetic_corpus(tmp_path)
    fit_trained(corpus, tmp_path / "model" / "trained", components=6)
    now = read_trained(tmp_path / "model" / "trained")
    manifest = tmp_path / "model" / "trained" / "trained.json"
    doc = json.loads(manifest.read_text())
    for fit in doc["fit"].values():
        if isinstance(fit, dict):
            fit.pop("amplitude_gain_cv", None)
    doc["selection"].pop("cv_gain")
    manifest.write_text(json.dumps(doc))
    old = read_trained(tmp_path / "model" / "trained")
    assert old.selection.cv_gain is False
    phones = _sentence(np.random.default_rng(7))
    timeline = plan(phones, default_table(), fps=30.0, duration=phones[-1].end)
    as_then = type(now)(**(now.__dict__ | {"selection": old.selection}))
    assert np.array_equal(old.target(timeline), as_then.target(timeline))
    assert not np.array_equal(old.target(timeline), now.target(timeline))
    assert old.plan(timeline)


def test_a_trained_face_keeps_its_fit_settings_apart_and_reads_one_that_mixed_them(
    tmp_path: Path,
) -> None:
    """The settings a face was fitted with are written apart from the selection's; a
    ``trained.json`` from before, which kept them among the selection's, reads the same."""
    import json

    from miketalk.draw.trained.training import FitSettings

    corpus = _synthetic_corpus(tmp_path)
    doc = fit_trained(corpus, tmp_path / "model" / "trained", components=6)
    assert doc["fitting"] == FitSettings().to_dict()
    assert not set(doc["fitting"]) & set(doc["selection"])
    now = read_trained(tmp_path / "model" / "trained")
    assert now.fitting == FitSettings()
    manifest = tmp_path / "model" / "trained" / "trained.json"
    before = json.loads(manifest.read_text())
    before["selection"] |= {"centred": True, "half": 4}
    del before["fitting"]
    manifest.write_text(json.dumps(before))
    old = read_trained(tmp_path / "model" / "trained")
    assert old.fitting == FitSettings(centred=True, half=4)
    assert old.selection == now.selection
    assert np.allclose(old.described().mean(axis=0), 0.0, atol=1e-9)  # centred


def test_a_trained_face_keeps_its_frames_visemes_and_one_fitted_before_draws_without(
    tmp_path: Path,
) -> None:
    """The frames' visemes are written with the face and steer the selection; a face
    written before them (no ``frames.viseme``, no ``viseme`` setting) draws as then."""
    import json

    corpus = _synthetic_corpus(tmp_path)
    fit_trained(corpus, tmp_path / "model" / "trained", components=6)
    now = read_trained(tmp_path / "model" / "trained")
    table = default_table()
    assert now.frame_visemes.shape == (len(now.frames.coords),)
    assert set(now.frame_visemes.tolist()) <= set(range(len(table.visemes)))
    assert len(set(now.frame_visemes.tolist())) > 3  # the synthetic speaker's phones
    phones = _sentence(np.random.default_rng(7))
    timeline = plan(phones, table, fps=30.0, duration=phones[-1].end)
    assert now.selection.viseme == 0.0  # off by default: it did not hold on held-out clips
    now = type(now)(**(now.__dict__ | {"selection": SelectionSettings(viseme=5.0)}))
    without = type(now)(**(now.__dict__ | {"frame_visemes": None}))
    # the chosen frames show the output frames' visemes more often with the cost than without
    times = np.array([f.time for f in timeline.frames])
    shown = now.trajectories["window"].context.labels(phones, times, table)[1]

    def agree(face) -> float:
        chosen = np.array([r[0][0] for r in face.plan(timeline)])
        return float(np.mean(now.frame_visemes[chosen] == shown))

    assert agree(now) > agree(without)
    # the face as it was written before the visemes were kept
    model = tmp_path / "model" / "trained"
    with np.load(model / "trajectory.npz") as z:
        arrays = {k: z[k] for k in z.files if k != "frames.viseme"}
    np.savez(model / "trajectory.npz", **arrays)
    doc = json.loads((model / "trained.json").read_text())
    doc["selection"].pop("viseme")
    (model / "trained.json").write_text(json.dumps(doc))
    old = read_trained(tmp_path / "model" / "trained")
    assert old.frame_visemes is None and old.selection.viseme == 0.0
    assert old.plan(timeline)


def test_a_model_without_a_trained_face_is_refused_in_one_line(tmp_path: Path) -> None:
    with pytest.raises(MiketalkError, match="no trained face") as err:
        read_trained(tmp_path)
    assert "\n" not in str(err.value)


def test_selection_settings_switch_old_and_new_and_centred_descriptions_fit(
    tmp_path: Path,
) -> None:
    """The previous selection settings render from the same model (paired comparison); the
    full gain makes the target move at least as far; centred fits are zero-mean per clip;
    settings fitted with the model cannot be overridden at render time."""
    from miketalk.draw.trained.build import fitted_face
    from miketalk.draw.trained.mouths import measure_frames
    from miketalk.draw.trained.selection import PREVIOUS_SELECTION
    from miketalk.draw.trained.training import FitSettings, clip_offsets
    from miketalk.visemes import VisemeTable

    corpus = _synthetic_corpus(tmp_path)
    fit_trained(corpus, tmp_path / "model" / "trained", components=6)
    trained = read_trained(tmp_path / "model" / "trained")
    phones = _sentence(np.random.default_rng(7))
    timeline = plan(phones, default_table(), fps=30.0, duration=phones[-1].end)
    old = SelectionSettings(**(SelectionSettings().to_dict() | PREVIOUS_SELECTION))
    new_target = trained.target(timeline)
    old_target = type(trained)(**(trained.__dict__ | {"selection": old})).target(timeline)
    # farther, not as far: the settings differ in the gain (measured: 15.3 against 12.9)
    assert new_target.std(axis=0).sum() > old_target.std(axis=0).sum()
    face = SimpleNamespace(directory=tmp_path / "model", image=lambda _: np.zeros((*SIZE, 3)))
    a = np.stack(list(render_trained(face, timeline, trained=trained)))
    b = np.stack(list(render_trained(face, timeline, trained=trained, selection=old.to_dict()
                                     | {"centred": False})))  # fmt: skip
    assert a.shape == b.shape
    assert not np.array_equal(a, b)  # the previous settings draw other frames (half of them)
    for fitted_with in ({"centred": True}, {"half": 3, "join": 2.0}):
        with pytest.raises(MiketalkError, match="fitted with the model; refit") as err:
            list(render_trained(face, timeline, trained=trained, selection=fitted_with))
        assert "\n" not in str(err.value)
    with pytest.raises(MiketalkError, match="unknown selection setting jion") as err:
        list(render_trained(face, timeline, trained=trained, selection={"jion": 1.0}))
    assert "\n" not in str(err.value)
    with pytest.raises(MiketalkError, match="no trajectory model 'splines'") as err:
        list(render_trained(face, timeline, trained=trained, kind="splines"))
    assert "\n" not in str(err.value)
    frames = measure_frames(corpus, components=6)
    centred = fitted_face(
        frames, corpus, selection=SelectionSettings(), fitting=FitSettings(centred=True),
        table=VisemeTable(),
    )  # fmt: skip
    described = centred.described()
    assert np.allclose(clip_offsets(frames)[frames.clip] + described, frames.coords)
    for c in range(len(frames.clip_ids)):
        assert np.allclose(described[frames.clip == c].mean(axis=0), 0.0, atol=1e-9)
    assert centred.plan(timeline)  # draws a sentence


def test_trajectory_cv_ridge_recovers_a_predictable_description_and_not_noise() -> None:
    from miketalk_lab.bench.trajectory_cv import cross_validated_r2, ridge_fit

    rng = np.random.default_rng(5)
    xs = [rng.integers(0, 2, size=(40, 6)).astype(float) for _ in range(10)]
    w = rng.normal(size=(6, 2))
    ys = [x @ w + 0.01 * rng.normal(size=(40, 2)) for x in xs]
    whole, per = cross_validated_r2(xs, ys, ridge_fit(1e-3))
    assert whole > 0.99 and (per > 0.99).all()
    noise = [rng.normal(size=(40, 2)) for _ in xs]
    assert cross_validated_r2(xs, noise, ridge_fit(1e-3))[0] < 0.05


def test_heldout_table_pairs_each_renderer_with_the_morph_by_clip() -> None:
    import pandas as pd

    from miketalk_lab.bench.heldout_table import MEASURES, main, tables

    rows = []
    for k, clip in enumerate(("a", "b", "c")):
        for renderer, shift in (("morph", 0.0), ("trained", 0.5 + k)):
            row = {m: 1.0 + k + shift for m in MEASURES} | {"lip_opening_lag": 2 * k}
            rows.append(row | {"clip": clip, "renderer": renderer, "model": "own"})
    spread, paired = tables(pd.DataFrame(rows), model="own")
    assert "| morph | 3 | 2.000 ± 1.000 |" in spread and spread.endswith("| 0.33 |")
    assert "| trained − morph | 3 | +1.500 (sd 1.000) |" in paired
    assert main(["/nonexistent/clips.csv"]) == 2


def test_a_trained_face_hears_a_recording_and_a_face_without_heard_does_not(
    tmp_path: Path,
) -> None:
    corpus = _synthetic_corpus(tmp_path)
    fit_trained(corpus, tmp_path / "model" / "trained", components=6)
    assert trained_trajectories(tmp_path / "model") == ("window", "regularized", "heard", "pooled")
    # a held-out clip dubbed by a trained face hears the clip's own recording
    assert dub_renderer("trained", tmp_path / "model") == "trained_heard"
    assert dub_renderer("paper", tmp_path / "model") == "morph"
    assert dub_renderer("learned", tmp_path / "model") == "learned"
    with pytest.raises(MiketalkError, match="lipsync model must be one of paper, learned, trained"):
        dub_renderer("mouthy", tmp_path / "model")
    face = read_trained(tmp_path / "model" / "trained")
    assert face.kind_for(None, recorded=True) == "heard"
    assert face.kind_for(None, recorded=False) == "window"
    assert face.kind_for("window", recorded=True) == "window"
    with pytest.raises(MiketalkError, match="listens to a recording") as err:
        face.kind_for("heard", recorded=False)
    assert "\n" not in str(err.value)
    phones = (Phone("pau", 0.0, 0.3), Phone("aa", 0.3, 0.6), Phone("pau", 0.6, 0.9))
    timeline = plan(phones, default_table(), fps=FPS, duration=0.9)
    sound = Recording(np.zeros(round(0.9 * RATE), np.int16), RATE)
    texture = np.full((120, 160), 150.0, np.float32)
    model = SimpleNamespace(
        directory=tmp_path / "model", image=lambda _: face_with(texture, phones, 0.0)
    )
    drawn = list(render_trained(model, timeline, trained=face, recording=sound))
    assert len(drawn) == len(timeline.frames)
    # a build that chose the pooled trajectory for a recording: dubbed and drawn along it
    manifest = tmp_path / "model" / "trained" / "trained.json"
    doc = json.loads(manifest.read_text())
    manifest.write_text(json.dumps(doc | {"recording": "pooled"}))
    assert dub_renderer("trained", tmp_path / "model") == "trained_pooled"
    pooled = read_trained(tmp_path / "model" / "trained")
    assert pooled.kind_for(None, recorded=True) == "pooled"
    assert pooled.kind_for(None, recorded=False) == "window"
    assert pooled.cost_weights("pooled").shape == (3,)
    assert pooled.cost_weights("pooled").min() > 0
    drawn = list(render_trained(model, timeline, trained=pooled, recording=sound))
    assert len(drawn) == len(timeline.frames)
    # a face fitted before the heard trajectory: read, drawn from its phones, heard refused
    del doc["trajectories"]["heard"], doc["fit"]["heard"]
    del doc["trajectories"]["pooled"], doc["fit"]["pooled"]
    manifest.write_text(json.dumps(doc))
    old = read_trained(tmp_path / "model" / "trained")
    assert tuple(old.trajectories) == ("window", "regularized")
    assert dub_renderer("trained", tmp_path / "model") == "trained"
    assert old.kind_for(None, recorded=True) == "window"
    with pytest.raises(MiketalkError, match="no trajectory model 'heard'"):
        old.kind_for("heard", recorded=True)


def test_a_trained_utterance_reports_the_persons_frames_not_the_visemes_morphs() -> None:
    from miketalk.cli.say import drawn_words
    from miketalk.lipsync.motion import measure
    from miketalk.lipsync.sampling import motion_blur

    phones = (Phone("pau", 0.0, 0.2), Phone("aa", 0.2, 0.3), Phone("m", 0.3, 0.4),
              Phone("pau", 0.4, 0.6))  # fmt: skip
    timeline = plan(phones, default_table(), fps=FPS, duration=0.6)
    # a fast transition: blur renders more morphs than frames for the paper's morph
    blurred = motion_blur(timeline, displacement=lambda a, b: 12.0, max_px_per_frame=2.0)
    morphed = measure(blurred, lambda a, b: 12.0, natural_duration=0.6)
    assert morphed.morphs > morphed.frames and morphed.largest_step_px <= 2.0 + 1e-9
    assert drawn_words(morphed).endswith(f"largest step {morphed.largest_step_px:.2f} px")
    own = measure(blurred, lambda a, b: 12.0, natural_duration=0.6, own_frames=True)
    assert own.morphs == own.frames == len(blurred.frames)
    assert own.largest_step_px is None and own.largest_frame_motion_px is None
    assert drawn_words(own).startswith(f"{own.frames} of the person's own frames (the step limit")
    json.dumps(own.to_dict(), allow_nan=False)


def test_selection_in_blocks_of_output_frames_chooses_as_all_at_once(monkeypatch) -> None:
    """Issue 50: the target costs of a 12-minute recording's 17,900 frames against every
    training frame were held at once (with their temporaries, most of say --audio's 2 GB);
    they are now one array, computed in place, and partitioned a block of output frames at a
    time, with the same path."""
    from miketalk.draw.trained import selection

    rng = np.random.default_rng(7)
    coords = rng.normal(size=(300, 16))
    frames = _frames(coords, np.repeat([0, 1, 2], 100))
    target = coords[rng.integers(0, 300, 230)] + rng.normal(scale=0.4, size=(230, 16))
    shown, recorded = rng.integers(0, 5, 230), rng.integers(0, 5, 300)
    for settings in (SelectionSettings(), SelectionSettings(viseme=2.0, candidates=7)):
        whole = select(frames, target, settings, visemes=(shown, recorded))
        monkeypatch.setattr(selection, "_BLOCK", 17)  # 14 blocks, the last short
        assert np.array_equal(select(frames, target, settings, visemes=(shown, recorded)), whole)
        assert len(set(whole.tolist())) > 50  # not one frame throughout
        monkeypatch.setattr(selection, "_BLOCK", 1024)


def _pause_features_by_table(phones, times, table) -> np.ndarray:
    """:func:`pause_features` as it was: a (times, phones) table of every gap (2 GB for a
    12-minute recording), the reference the sorted search must equal."""
    from miketalk.draw.trained.trajectory import SILENCE

    spoken = [p for p in phones if SILENCE not in table.visemes_of(p.name)]
    n_bins = len(PAUSE_BINS) + 1
    out = np.zeros((len(times), 2 * n_bins))
    if not spoken:
        return out
    starts, ends = np.array([p.start for p in spoken]), np.array([p.end for p in spoken])
    inside = ((times[:, None] >= starts[None, :]) & (times[:, None] < ends[None, :])).any(axis=1)
    ahead = np.where(starts[None, :] >= times[:, None], starts[None, :] - times[:, None], np.inf)
    behind = np.where(ends[None, :] <= times[:, None], times[:, None] - ends[None, :], np.inf)
    rows = np.arange(len(times))
    for column, gap in ((0, ahead.min(axis=1)), (n_bins, behind.min(axis=1))):
        ok = ~inside & np.isfinite(gap)
        out[rows[ok], column + np.searchsorted(PAUSE_BINS, gap[ok])] = 1.0
    return out


def test_pause_features_by_sorted_search_are_the_tables() -> None:
    rng = np.random.default_rng(0)
    names = ["pau", "aa", "b", "iy", "s", "t"]
    times = np.arange(-1.0, 12.0, 0.04)
    for trial in range(60):
        n = int(rng.integers(0, 40))
        starts = rng.uniform(0, 10, n).round(2)
        if trial % 3:  # in order, as aligned; else unsorted and overlapping
            starts = np.sort(starts)
        lengths = rng.uniform(0.01, 0.5, n).round(2)
        phones = [Phone(str(rng.choice(names)), float(a), float(a + d))
                  for a, d in zip(starts, lengths, strict=True)]  # fmt: skip
        expected = _pause_features_by_table(phones, times, default_table())
        assert np.array_equal(pause_features(phones, times, default_table()), expected), trial
