"""Face tracking (miketalk.track), the canonical crop and hard s1 (miketalk_lab.hard_s1).

Everything runs on the first frames of one committed GRID clip, moved, doubled or blanked
here with known transforms, at small sizes: the whole file takes a few seconds.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from miketalk.errors import MiketalkError
from miketalk.media.decode import iter_video_frames, read_video
from miketalk.track import (
    CANONICAL_LANDMARKS,
    FaceCropSettings,
    Failure,
    apply_affine,
    face_crop,
    face_mask,
    fit_similarity,
    from_pose_parameters,
    invert_affine,
    iter_face_crops,
    paste_back,
    pose_parameters,
    track_frames,
)
from miketalk.track.similarity import compose_affine
from miketalk.track.smooth import smooth_poses, smooth_transforms
from miketalk_lab.hard_s1 import chroma_alpha, hard_frames, hard_motion, make_hard_clip, room

ROOT = Path(__file__).resolve().parents[2]
CLIP = ROOT / "data" / "grid_s1" / "video" / "bbaf2n.mpg"
FPS = 25.0


@pytest.fixture(scope="module")
def s1() -> np.ndarray:
    """The clip's first 16 frames (360x288; frames of GRID's silence, a still head)."""
    frames, _ = read_video(CLIP, frames=16)
    return frames


def _similarity(angle_deg: float, scale: float, tx: float, ty: float) -> np.ndarray:
    a = np.radians(angle_deg)
    c, s = scale * np.cos(a), scale * np.sin(a)
    return np.array([[c, -s, tx], [s, c, ty]])


def _moved(frames: np.ndarray, motions: np.ndarray, size: tuple[int, int]) -> list[np.ndarray]:
    return [
        cv2.warpAffine(f, m, size, flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REPLICATE)
        for f, m in zip(frames, motions, strict=True)
    ]


def _rms(differences: np.ndarray) -> float:
    """The RMS length of ``(n, 2)`` point differences."""
    return float(np.sqrt((differences**2).sum(axis=1).mean()))


def _points(transform: np.ndarray) -> np.ndarray:
    """The canonical face points in the frame, through a frame-to-canonical transform."""
    return apply_affine(invert_affine(transform), CANONICAL_LANDMARKS)


def test_similarity_fit_and_pose_round_trip() -> None:
    rng = np.random.default_rng(3)
    source = rng.uniform(0, 300, (5, 2))
    known = _similarity(12.0, 0.03, -4.0, 2.5)
    fitted = fit_similarity(source, apply_affine(known, source))
    np.testing.assert_allclose(fitted, known, atol=1e-12)
    np.testing.assert_allclose(from_pose_parameters(pose_parameters(known)), known, atol=1e-12)
    # the pose: the eye distance in frame pixels and where the canonical origin is
    log_scale, _, x, y = pose_parameters(known)
    assert np.exp(log_scale) == pytest.approx(1 / 0.03)
    np.testing.assert_allclose([x, y], apply_affine(invert_affine(known), [0.0, 0.0]))
    with pytest.raises(MiketalkError, match="coincide"):
        fit_similarity(np.ones((5, 2)), source)


def test_tracking_recovers_a_known_motion(s1: np.ndarray) -> None:
    # the clip moved by a similarity that turns, grows and slides over the frames, into a
    # larger frame: the face points tracked in the moved frames are the plain clip's,
    # moved (the head is still, so the comparison holds frame by frame)
    n = len(s1)
    t = np.arange(n) / (n - 1)
    motions = np.stack(
        [
            _similarity(6 * t[k] - 3, 1.3 + 0.1 * t[k], 40 + 30 * t[k], 20 - 15 * t[k])
            for k in range(n)
        ]
    )
    moved = _moved(s1, motions, (560, 420))
    plain = track_frames(s1, fps=FPS)
    track = track_frames(moved, fps=FPS)
    assert plain.tracked.all() and track.tracked.all()
    errors = [
        _rms(_points(track.transforms[k]) - apply_affine(motions[k], _points(plain.transforms[k])))
        for k in range(n)
    ]
    eye_distance = np.exp(pose_parameters(track.transforms[0])[0])
    assert 55 < eye_distance < 70  # s1's ~47 px times 1.3
    assert max(errors) < 0.8, errors  # pixels (measured: 0.35 at most)
    # the crop puts the eyes where the settings say
    settings = FaceCropSettings(size=128, eye_distance=36.0)
    m = settings.transform(track.transforms[5])
    eyes = apply_affine(m, track.landmarks[5][:4]).reshape(2, 2, 2).mean(axis=1)
    np.testing.assert_allclose(eyes[:, 1], 0.36 * 128 - 0.5, atol=1.5)
    # 36 px apart for the canonical face: s1's own eyes, fitted with his longer nose, a
    # little closer
    assert 0.9 < abs(eyes[0, 0] - eyes[1, 0]) / 36.0 < 1.0


def test_a_frame_without_a_face_is_reported_and_left_out(s1: np.ndarray) -> None:
    frames = list(s1[:8])
    blank = cv2.GaussianBlur(np.random.default_rng(0).integers(0, 255, s1[0].shape, np.uint8),
                             (0, 0), 3)  # fmt: skip
    frames[3] = blank
    frames[4] = blank
    track = track_frames(frames, fps=FPS)
    assert track.reasons[3] == Failure.NO_FACE and track.reasons[4] == Failure.NO_FACE
    assert track.transform(3) is None and np.isnan(track.transforms[4]).all()
    assert [(f.start, f.stop, f.reason) for f in track.failures()] == [(3, 5, Failure.NO_FACE)]
    assert track.segments == ((0, 3), (5, 8))  # the track goes on after the gap
    assert track.cuts() == []  # a gap, not a cut
    assert "frames 3-4: no frontal face" in track.summary()


def test_a_turned_or_covered_face_is_left_out(s1: np.ndarray) -> None:
    # squeezed to 0.55 of its width, as a head turned by more than 50 degrees
    turned = [cv2.resize(f, (198, 288), interpolation=cv2.INTER_AREA) for f in s1[:3]]
    track = track_frames(turned, fps=FPS)
    assert not track.tracked.any()
    assert set(track.reasons) <= {Failure.POOR_FIT, Failure.NO_FACE}
    # the eyes under a band for three frames: the landmarks there would be guesses
    covered = [f.copy() for f in s1[:8]]
    for f in covered[3:6]:
        f[130:170] = 128
    track = track_frames(covered, fps=FPS)
    assert track.tracked.tolist() == [True] * 3 + [False] * 3 + [True] * 2


def test_two_faces_side_by_side_are_reported(s1: np.ndarray) -> None:
    two = [np.concatenate([f, f[:, ::-1]], axis=1) for f in s1[:3]]
    track = track_frames(two, fps=FPS)
    assert track.reasons == (Failure.SEVERAL_FACES,) * 3
    assert not track.segments
    # one of them alone is tracked
    assert track_frames([f[:, :360] for f in two], fps=FPS).tracked.all()


def test_a_jump_is_a_cut_and_smoothing_does_not_cross_it(s1: np.ndarray) -> None:
    # the same head, 90 px further right from frame 8 on (a jump cut)
    motions = np.stack([_similarity(0, 1.0, 20 if k < 8 else 110, 10) for k in range(16)])
    track = track_frames(_moved(s1, motions, (480, 300)), fps=FPS)
    assert track.tracked.all()
    assert track.segments == ((0, 8), (8, 16)) and track.cuts() == [8]
    # either side of the cut, the smoothed face is where that side's raw fits put it
    for k in (7, 8):
        assert np.abs(_points(track.transforms[k]) - _points(track.raw[k])).max() < 1.0
    # smoothed as one segment it would be dragged towards the other side
    across, _ = smooth_transforms(track.raw, [(0, 16)], sigma=0.15 * FPS)
    assert np.abs(_points(across[7]) - _points(track.raw[7])).max() > 3.0


def test_smoothing_replaces_a_glitch_and_follows_a_fast_move() -> None:
    n = 40
    k = np.arange(n, dtype=float)
    poses = np.zeros((n, 4))
    poses[:, 0] = np.log(100.0)  # an eye distance of 100 px
    poses[:, 2] = 300 + 60 * np.tanh((k - 20) / 2.5)  # a fast sideways move: 120 px
    poses[:, 3] = 200.0
    noisy = poses + np.random.default_rng(1).normal(0, 0.3, poses.shape) * [0.003, 0.003, 1, 1]
    noisy[10, 3] += 25.0  # a glitch
    smoothed, outliers = smooth_poses(noisy, sigma=4.5, gamma=1.0)
    assert outliers.tolist() == [i == 10 for i in range(n)]
    assert abs(smoothed[10, 3] - 200.0) < 1.0
    # the move is followed, not lagged: within the noise everywhere
    assert np.abs(smoothed[:, 2] - poses[:, 2]).max() < 1.2
    # and where the head is still, jitter is removed
    assert np.std(smoothed[28:38, 3] - 200.0) < 0.6 * np.std(noisy[28:38, 3] - 200.0)


def test_crop_and_paste_back_round_trip_at_full_resolution(s1: np.ndarray) -> None:
    # a 1280x720 frame holding the s1 frame scaled by 2.1; the crop's face is a little
    # larger (the round trip enlarges, then shrinks), so it keeps the frame's detail
    motion = _similarity(4.0, 2.1, 300, -40)
    frame = _moved(s1[:1], motion[None], (1280, 720))[0]
    track = track_frames([frame], fps=FPS)
    settings = FaceCropSettings(size=320, eye_distance=110.0)
    m = settings.transform(track.transforms[0])
    crop = face_crop(frame, track.transforms[0], settings)
    assert crop.shape == (320, 320, 3) and crop.dtype == np.uint8
    mask = face_mask(settings)
    back = paste_back(frame, crop, m, mask)
    assert back.shape == frame.shape and back.dtype == np.uint8
    inside = cv2.warpAffine(mask, invert_affine(m), (1280, 720)) > 0.99
    assert inside.sum() > 25_000
    diff = np.abs(back.astype(int) - frame.astype(int)).max(axis=2)
    assert diff[inside].mean() < 1.0 and np.percentile(diff[inside], 99) <= 4
    # outside the crop the frame is untouched, and a different image does show inside
    covered = cv2.warpAffine(np.ones((320, 320), np.float32), invert_affine(m), (1280, 720)) > 0
    assert np.array_equal(back[~covered], frame[~covered])
    grey = paste_back(frame, np.full_like(crop, 128), m, mask)
    assert np.abs(grey[inside].astype(int) - 128).max() <= 1


def test_face_crops_stream_skips_frames_left_out(s1: np.ndarray) -> None:
    transforms = np.full((4, 2, 3), np.nan)
    transforms[1] = transforms[3] = fit_similarity(
        np.array([[180, 150], [160, 150], [120, 150], [140, 150], [150, 185]], float),
        CANONICAL_LANDMARKS,
    )
    crops = list(
        iter_face_crops(iter(s1[:4]), transforms, FaceCropSettings(size=64, eye_distance=18))
    )
    assert [i for i, _ in crops] == [1, 3] and crops[0][1].shape == (64, 64, 3)
    with pytest.raises(MiketalkError, match="no transform"):
        list(iter_face_crops(iter(s1[:5]), transforms))


def test_streaming_reader_gives_read_video_s_frames(s1: np.ndarray) -> None:
    streamed = list(iter_video_frames(CLIP, frames=16))
    assert np.array_equal(np.stack(streamed), s1)
    stream = iter_video_frames(CLIP)
    assert next(stream).shape == (288, 360, 3)
    stream.close()  # stops ffmpeg; no error


def test_hard_s1_is_deterministic(s1: np.ndarray, tmp_path: Path) -> None:
    size = (640, 360)
    truth = hard_motion(20, FPS, size=size, seed=5, name="bbaf2n")
    assert np.array_equal(truth, hard_motion(20, FPS, size=size, seed=5, name="bbaf2n"))
    assert not np.array_equal(truth, hard_motion(20, FPS, size=size, seed=6, name="bbaf2n"))
    back = room(size, seed=5)
    assert np.array_equal(back, room(size, seed=5))
    first = np.stack(list(hard_frames(s1, truth[:16], back)))
    assert np.array_equal(first, np.stack(list(hard_frames(s1, truth[:16], room(size, seed=5)))))
    a = make_hard_clip(CLIP, tmp_path / "a.mp4", size=size, seed=5, frames=20)
    b = make_hard_clip(CLIP, tmp_path / "b.mp4", size=size, seed=5, frames=20)
    assert a.path.read_bytes() == b.path.read_bytes()
    assert np.array_equal(a.truth, truth)


def test_hard_s1_truth_maps_the_clip_onto_the_hard_frame(s1: np.ndarray) -> None:
    # the hard frame warped back by the truth is the plain frame where the person is
    size = (640, 360)
    truth = hard_motion(16, FPS, size=size, seed=2, name="bbaf2n")
    hard = list(hard_frames(s1, truth, room(size, seed=2)))

    def difference(k: int, shift: float) -> float:
        wrong = compose_affine(np.array([[1.0, 0.0, shift], [0.0, 1.0, 0.0]]), truth[k])
        back = cv2.warpAffine(hard[k], invert_affine(wrong), (360, 288), flags=cv2.INTER_CUBIC)
        person = cv2.erode((chroma_alpha(s1[k]) > 0.99).astype(np.uint8), np.ones((7, 7)))
        person[250:] = 0  # the clip's bottom edge, repeated below it in the hard frame
        d = np.abs(back.astype(float) - s1[k].astype(float)).mean(axis=2)
        return float(d[person.astype(bool)].mean())

    for k in (0, 9, 15):
        right, shifted = difference(k, 0.0), difference(k, 1.5)
        assert right < 3.0 and right < 0.6 * shifted, (k, right, shifted)
