"""Tests of miketalk_lab.evaluation.dub_crop: a face-crop model's held-out dub, its pieces
(the end-to-end run needs a crop model, which takes minutes to build: docs/dub.md)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from miketalk.corpus.clip_sources import Clip
from miketalk.errors import MiketalkError
from miketalk.speech.word_timings import WordTiming
from miketalk_lab.evaluation.dub_crop import (
    CropDub,
    lipsync_of,
    mouth_span,
    paste_measures,
    shared_frames,
)
from miketalk_lab.evaluation.dub_heldout import _check_product_settings

DATA = Path(__file__).resolve().parents[2] / "data" / "grid_s1"


def _dub(tmp_path: Path, change: float, *, jaw: int = 0) -> CropDub:
    """Six textured 48x64 frames, the dub changed by ``change`` where its blend mask is 1
    (two pixels inside it), the mask 1 in a square, 0.5 on a ring around it, 0 beyond."""
    from miketalk.media.video import write_mp4

    rng = np.random.default_rng(1)
    noise = rng.integers(40, 200, (6, 48, 64, 3)).astype(np.uint8)
    source = np.stack([cv2.GaussianBlur(f, (0, 0), 1.5) for f in noise])  # texture codecs keep
    alpha = np.zeros((20, 24), np.float32)
    alpha[2:-2, 2:-2] = 0.5
    alpha[5:-5, 5:-5] = 1.0
    frames = source.copy()
    box = (30, 20, 54, 40)  # (x0, y0, x1, y1): 24 wide, 20 high
    frames[:, 20 + 7 : 40 - 7, 30 + 7 : 54 - 7] = np.clip(
        source[:, 27:33, 37:47].astype(int) + change, 0, 255
    )
    frames[:5, 20:22, 30:33] = np.clip(source[:5, 20:22, 30:33].astype(int) + jaw, 0, 255)
    video = tmp_path / "dub.mp4"
    write_mp4(video, frames, fps=25, crf=0)
    boxes = [box] * 5 + [None]  # the last frame untracked: nothing placed
    alphas = [alpha] * 5 + [None]
    frames[5] = source[5]
    renders = np.zeros((6, 16, 16, 3), np.uint8)
    return CropDub(video, None, frames, source, renders, boxes, alphas, 25.0, 0.0)


def test_a_paste_back_inside_its_mask_leaves_the_rest_bit_identical(tmp_path: Path) -> None:
    measures = paste_measures(_dub(tmp_path, 60))
    assert measures["identical_outside_box"] == 1.0
    assert measures["psnr_outside"] == float("inf")  # nothing changed where alpha is 0
    assert measures["moved_outside_px"] == 0
    changed = 5 * 6 * 10 / (6 * 48 * 64)
    assert measures["identical_share"] == pytest.approx(1 - changed, abs=1e-3)
    assert measures["seam_ratio"] == pytest.approx(1.0)  # the ring is the source's own
    assert np.isfinite(measures["psnr_frame"]) and measures["psnr_encoded"] > 30
    jaw = paste_measures(_dub(tmp_path, 60, jaw=20))  # the box's corner, outside the mask
    assert jaw["moved_outside_px"] == 5 * 6 / 6 and jaw["identical_outside_box"] == 1.0
    assert np.isfinite(jaw["psnr_outside"])
    same = paste_measures(_dub(tmp_path, 0))
    assert same["identical_share"] == 1.0 and same["psnr_frame"] == float("inf")


def test_the_strips_mouth_holds_every_placed_box(tmp_path: Path) -> None:
    dub = _dub(tmp_path, 10)
    assert mouth_span(dub, 40) == (30, 20, 24, 20)
    none = CropDub(dub.video, None, dub.frames, dub.source, dub.renders, [None], [None], 25, 0)
    assert mouth_span(none, 40) is None


def test_the_real_clip_and_the_dub_are_compared_on_the_frames_both_kept() -> None:
    # both kept every frame: all 75, the speech as it was
    assert shared_frames((0, 75), (0, 75), 74, slice(10, 60)) == (0, 74, slice(10, 60))
    # the real clip lost its first 4 frames, the dub its last 3: frames 4 to 72
    lo, hi, speech = shared_frames((4, 71), (0, 72), 75, slice(6, 50))
    assert (lo, hi) == (4, 72) and speech == slice(6, 50)
    # the dub lost its first 8: the real clip's speech starts 4 frames earlier in the window
    assert shared_frames((4, 71), (8, 67), 75, slice(6, 50)) == (8, 75, slice(2, 46))
    assert shared_frames((0, 75), (0, 75), 75, slice(70, 90)) == (0, 75, slice(70, 75))
    lo, hi, speech = shared_frames((50, 10), (0, 20), 75, slice(0, 5))
    assert hi <= lo and speech.stop == speech.start  # nothing shared


def test_a_renderer_is_dubbed_as_the_product_draws_it() -> None:
    assert lipsync_of("trained_heard", "unused") == ("trained", "heard")
    assert lipsync_of("learned", "unused") == ("learned", None)
    assert lipsync_of("morph", "unused") == ("paper", None)
    with pytest.raises(MiketalkError, match="cannot dub with 'still'"):
        lipsync_of("still", "unused")


def test_a_crop_model_is_dubbed_with_the_products_compositing_only() -> None:
    from miketalk import defaults

    _check_product_settings(colour="clip", blend=None, method="feather",
                            smooth=defaults.BACKGROUND_SMOOTH, follow=defaults.BLEND_FOLLOW,
                            skin=defaults.BLEND_SKIN,
                            interpolation=defaults.BLEND_INTERPOLATION)  # fmt: skip
    with pytest.raises(MiketalkError, match=r"not method='poisson'$"):
        _check_product_settings(colour="clip", blend=None, method="poisson",
                                smooth=defaults.BACKGROUND_SMOOTH, follow=defaults.BLEND_FOLLOW,
                                skin=defaults.BLEND_SKIN,
                                interpolation=defaults.BLEND_INTERPOLATION)  # fmt: skip


def test_a_clip_cut_from_one_video_is_given_to_dub_as_a_recording_and_its_words(
    tmp_path: Path,
) -> None:
    from miketalk.media.decode import read_media_audio
    from miketalk.speech.word_timings import read_word_timings
    from miketalk_lab.evaluation.dub_crop import _product_inputs

    words = (WordTiming("bin", 0.2, 0.5), WordTiming("blue", 0.5, 0.9))
    clip = Clip("u1", DATA / "video" / "bbas3a.mpg", "bin blue", span=(10, 40), fps=25.0,
                given_words=words)  # fmt: skip
    audio, timings, text, part = _product_inputs(clip, tmp_path)
    assert part == {"start": 0.4, "frames": 40} and text is None
    assert len(read_media_audio(audio, rate=16000)) == 16000 * 40 // 25
    assert [(w.word, w.start, w.end) for w in read_word_timings(timings)] == [
        ("bin", 0.2, 0.5),
        ("blue", 0.5, 0.9),
    ]
    whole = Clip("bbas3a", DATA / "video" / "bbas3a.mpg", "bin blue at s three again",
                 timings=DATA / "align" / "bbas3a.align")  # fmt: skip
    assert _product_inputs(whole, tmp_path) == (whole.media, whole.timings, None, {})
