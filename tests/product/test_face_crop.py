"""The face-crop path: tracked crops of a video, ECC kept only where it refines, frames read
when played, loops inside one shot, clips cut at shot changes, backgrounds composed back
into the full-resolution frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from miketalk.composite.loop import still_window
from miketalk.corpus.clip_sources import Clip, DecodedClip
from miketalk.media.decode import read_video
from miketalk.media.frame_source import ImageFrames, VideoFrames
from miketalk.media.images import write_png
from miketalk.speech.types import Phone
from miketalk.speech.word_timings import WordTiming
from miketalk.track.crop import FaceCropSettings, crop_doc, crop_from_doc, mouth_box
from miketalk.track.refine import IDENTITY, refined
from miketalk.track.similarity import apply_affine, invert_affine
from miketalk.track.video_crops import crop_video, nearest_tracked
from miketalk_lab.hard_s1 import make_hard_clip

CLIP = Path(__file__).parents[2] / "data" / "grid_s1" / "video" / "bbaf2n.mpg"


def test_nearest_tracked_takes_the_nearest_finite_transform() -> None:
    t = np.full((6, 2, 3), np.nan)
    t[1], t[4] = 1.0, 4.0
    filled = nearest_tracked(t)
    assert filled[:, 0, 0].tolist() == [1, 1, 1, 4, 4, 4]  # frame 2: nearer 1; 3: nearer 4


def test_refined_keeps_a_small_refinement_and_overrules_a_wrong_one() -> None:
    small = IDENTITY + np.array([[0.0, 0.0, 0.5], [0.0, 0.0, -0.3]])
    wrong = np.array([[1.2, 0.1, -20.0], [0.0, 0.9, 5.0]])
    t = np.stack([small, wrong, np.full((2, 3), np.nan), small])
    tracked = np.array([True, True, True, False])
    out, replaced = refined(t, tracked, (50, 50, 100, 60), limit=3.0)
    assert replaced == 2  # the wrong one and the failed one
    np.testing.assert_allclose(out[0], small)
    np.testing.assert_allclose(out[1], IDENTITY)
    np.testing.assert_allclose(out[2], IDENTITY)
    assert np.isnan(out[3]).all()  # not tracked: never the face


def test_the_canonical_mouth_box_holds_the_lips_and_scales_with_the_crop() -> None:
    x, y, w, h = mouth_box(FaceCropSettings())
    assert (x, y, w, h) == (92, 164, 72, 28)
    big = FaceCropSettings(size=512, eye_distance=144.0)
    assert mouth_box(big)[2] == 2 * w
    assert crop_from_doc(crop_doc(big)) == big and crop_from_doc(None) is None


def test_video_frames_read_backwards_and_forwards_as_the_whole_video() -> None:
    whole, fps = read_video(CLIP)
    frames = VideoFrames(CLIP, count=len(whole), fps=fps, keep=8)
    assert frames.shape == whole.shape
    order = [0, 1, 2, 40, 41, 39, 30, 29, 74, 3, 74, 73]
    for i in order:
        assert np.array_equal(frames[i], whole[i]), i
    part = frames[10:14]
    assert len(part) == 4 and np.array_equal(part[3], whole[13])
    frames.close()


def test_image_frames_are_read_when_asked_for(tmp_path: Path) -> None:
    images = np.random.default_rng(0).integers(0, 255, (5, 8, 10, 3), dtype=np.uint8)
    paths = []
    for i, image in enumerate(images):
        write_png(tmp_path / f"{i}.png", image)
        paths.append(tmp_path / f"{i}.png")
    frames = ImageFrames(paths, keep=2)
    assert frames.shape == (5, 8, 10, 3)
    assert all(np.array_equal(frames[i], images[i]) for i in (4, 0, 3, 3, 1))
    with pytest.raises(IndexError):
        frames[5]


def test_the_loop_stays_inside_one_shot() -> None:
    speed = np.ones(40)
    speed[[5, 30]] = 0.0  # the stillest ends lie across the cut at 20
    shot = np.repeat([0, 1], 20)
    assert still_window(speed, (), shortest=10, longest=30) == (5, 31)
    start, stop = still_window(speed, (), shortest=10, longest=30, shot=shot)
    assert shot[start] == shot[stop - 1]
    shot[:25] = -1  # frames without a face are never played
    start, _ = still_window(speed, (), shortest=10, longest=30, shot=shot)
    assert start >= 25


def test_a_clip_is_cut_at_its_shot_changes() -> None:
    n, fps = 30, 25.0
    phones = (Phone("b", 0.0, 0.5), Phone("ih", 0.5, 1.2))
    words = (WordTiming("bin", 0.0, 1.2),)
    decoded = DecodedClip(
        Clip("u1", Path("v.mp4"), "bin", span=(100, n), fps=fps),
        np.zeros((n, 4, 4, 3), np.uint8), fps, np.zeros(int(n / fps * 16000), np.int16),
        phones, words, (None,) * n, np.zeros((n, 2, 3)), (12,),
    )  # fmt: skip
    first, second = decoded.shots()
    assert (first.clip.id, second.clip.id) == ("u1.1", "u1.2")
    assert (first.clip.span, second.clip.span) == ((100, 12), (112, 18))
    assert len(first.frames) == 12 and second.phones[0].start == 0.0
    assert first.cuts == () and second.cuts == ()


@pytest.mark.slow
def test_crops_of_a_moving_hd_face_keep_it_in_place(tmp_path: Path) -> None:
    hard = make_hard_clip(CLIP, tmp_path / "hard.mp4", frames=40, seed=3)
    settings = FaceCropSettings()
    cropped = crop_video(tmp_path / "hard.mp4", crop=settings)
    assert cropped.crops.shape == (40, 256, 256, 3) and cropped.tracked.all()
    assert cropped.size == (1280, 720)
    # a point of the clip's face lands where it lands in the crops of the clip itself
    # (the head's own motion is in both; the hard frames' known motion is taken out)
    plain = crop_video(CLIP, crop=settings, frames=40)
    point = np.array([[180.0, 170.0]])
    in_crop = np.array(
        [apply_affine(cropped.to_crop[i], apply_affine(hard.truth[i], point))[0] for i in range(40)]
    )
    in_plain = np.array([apply_affine(plain.to_crop[i], point)[0] for i in range(40)])
    assert np.sqrt(np.mean(np.sum((in_crop - in_plain) ** 2, axis=1))) < 1.5
    back = apply_affine(cropped.to_frame(7), in_crop[7][None])[0]
    np.testing.assert_allclose(back, apply_affine(hard.truth[7], point)[0], atol=1e-6)
    assert np.allclose(invert_affine(cropped.to_frame(7)), cropped.to_crop[7])


def test_a_clips_light_is_offset_to_the_references() -> None:
    from miketalk.corpus.light import match_light

    rng = np.random.default_rng(1)
    reference = rng.integers(60, 200, (32, 32, 3)).astype(np.uint8)
    darker = np.stack([reference.astype(int) - [30, 10, 20]] * 4).clip(0, 255).astype(np.uint8)
    mask = np.zeros((32, 32), bool)
    mask[4:28, 4:28] = True
    out, gain, offset = match_light(darker, reference, mask, spread=False)
    assert gain.tolist() == [1.0, 1.0, 1.0]
    np.testing.assert_allclose(offset, [30, 10, 20], atol=0.01)
    assert np.abs(out[0].astype(int) - reference).max() <= 1


def test_the_jaw_mask_lies_inside_the_face_mask() -> None:
    from miketalk.track.crop import face_mask, jaw_mask

    settings = FaceCropSettings()
    jaw, face = jaw_mask(settings), face_mask(settings)
    assert (jaw <= face + 0.05).all()
    x, y, w, h = mouth_box(settings)
    assert jaw[y + h // 2, x + w // 2] > 0.99  # the mouth is inside
    assert jaw[250, 128] < 0.01 and jaw[180, 20] < 0.01  # below the chin, beyond the cheek


@pytest.mark.slow
def test_a_face_crop_model_speaks_into_the_videos_own_frames(
    s1_crop_built: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``miketalk build``'s default (the face crop) end to end: the model works in the crop,
    its own background plays at the video's size and rate, and a dub of an HD video of the
    same man, moving, comes out at that video's size with its frames outside the mouth kept;
    a second dub of it reads its registration from the cache."""
    import json

    from miketalk import cli

    model = s1_crop_built
    assert json.loads((model / "manifest.json").read_text())["size"] == [256, 256]
    assert json.loads((model / "background" / "background.json").read_text())["crop"]
    said = tmp_path / "said.mp4"
    assert cli.main(["say", "Bin blue at F two now.", "--model", str(model), "-o", str(said)]) == 0
    frames, fps = read_video(said)
    assert frames.shape[1:3] == (288, 360) and fps == 25.0  # the video's own
    hard = make_hard_clip(CLIP, tmp_path / "hard.mp4", seed=5)
    dubbed = tmp_path / "dubbed.mp4"
    args = ["dub", str(hard.path), "--text", "Bin blue.", "--model", str(model), "-o", str(dubbed)]
    assert cli.main(args) == 0
    out, _ = read_video(dubbed)
    source, _ = read_video(hard.path)
    assert out.shape[1:] == (720, 1280, 3)
    changed = np.abs(out[20].astype(int) - source[20].astype(int)).max(axis=2) > 12
    ys, xs = np.nonzero(changed)
    mouth = apply_affine(hard.truth[20], np.array([[160.0, 221.0]]))[0]  # s1's lips
    assert changed.mean() < 0.02  # the mouth's pixels only
    assert abs(np.median(xs) - mouth[0]) < 30 and abs(np.median(ys) - mouth[1]) < 30
    # a second dub of the same video with the same model: its registration is read from
    # the cache (:mod:`miketalk.composite.kept_registration`), not tracked again: the same bytes
    from miketalk.track import video_crops

    def tracked_again(*args, **kwargs):
        raise AssertionError("the video was tracked again")

    monkeypatch.setattr(video_crops, "crop_video", tracked_again)
    again = tmp_path / "again.mp4"
    args = ["dub", str(hard.path), "--text", "Bin blue.", "--model", str(model), "-o", str(again)]
    assert cli.main(args) == 0
    assert again.read_bytes() == dubbed.read_bytes()
