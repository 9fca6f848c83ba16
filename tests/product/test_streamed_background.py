"""A video under the mouth (``dub``, ``say --background VIDEO``) is streamed, never held whole.

Issue 50: a model in the frames' own pixels read the whole video at its own size (twice,
and scaled): 3 s of 1080p held 1.49 GB, 9 s 4.23 GB. The mechanism is tested here, not the
memory: the frames played are a :class:`~miketalk.media.frame_source.VideoFrames` holding a
bounded window, and they and the registration are those of the whole read.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_dub import _model
from test_stabilize import _clip, _write_video

from miketalk.composite.background import background_from_video
from miketalk.composite.for_model import video_background
from miketalk.media import frame_source
from miketalk.media.decode import read_video
from miketalk.media.frame_source import VideoFrames
from miketalk.model.face import Model


@pytest.fixture(scope="module")
def person(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _model(tmp_path_factory.mktemp("person"), person=True)


@pytest.fixture(scope="module")
def video(tmp_path_factory: pytest.TempPathFactory) -> Path:
    frames, _ = _clip(30)  # 1.2 s at 25 fps
    path = tmp_path_factory.mktemp("video") / "person.mkv"
    _write_video(path, frames, "25")
    return path


def test_a_full_frame_models_video_is_streamed_with_the_whole_reads_frames(person, video):
    model = Model(person)
    background = video_background(model, video)
    assert isinstance(background.frames, VideoFrames)  # not an array of every frame
    frames, fps = read_video(video)
    assert len(background) == len(frames) and background.fps == fps
    assert all(np.array_equal(background.frames[i], frames[i]) for i in range(len(frames)))
    held = background_from_video(frames, fps, model.stabilizer(), source=str(video))
    np.testing.assert_array_equal(background.transforms, held.transforms)
    assert background.blinks == held.blinks
    np.testing.assert_array_equal(background.steady, held.steady)


def test_a_video_keeps_at_most_its_byte_budget_of_frames(video, monkeypatch):
    frame_bytes = int(np.prod(read_video(video, frames=1)[0].shape[1:]))
    monkeypatch.setattr(frame_source, "KEEP_BYTES", 3 * frame_bytes)
    frames = VideoFrames(video, count=30, fps=25.0, keep=32)
    for i in [*range(30), *range(29, -1, -1)]:  # forwards and back, as the ping-pong plays
        frames[i]
        assert len(frames._cache) <= 3
    monkeypatch.setattr(frame_source, "KEEP_BYTES", 0)
    frames = VideoFrames(video, count=30, fps=25.0, keep=32)
    for i in range(30):
        frames[i]
    assert len(frames._cache) == 2  # at least two, whatever the budget


def test_registration_stabilizes_a_chunk_at_a_time_with_the_whole_videos_result(person):
    """The stabilized copy of every frame (as much again as the frames registered) is no
    longer held: the frames are stabilized 50 at a time, and the blinks and the light are
    those of the whole stabilized video."""
    from miketalk.composite.blinks import find_blinks
    from miketalk.composite.registration import _CHUNK, _SAMPLE, register_video

    frames, _ = _clip(120)
    stabilizer = Model(person).stabilizer()
    sizes, apply = [], stabilizer.apply

    def counted(chunk, transforms, **kwargs):
        sizes.append(len(chunk))
        return apply(chunk, transforms, **kwargs)

    stabilizer.apply = counted
    found = register_video(frames, 25.0, stabilizer, smooth=0)
    # the conform field reads at most _SAMPLE frames; the rest a chunk at a time
    assert max(sizes) <= max(_CHUNK, _SAMPLE) < len(frames)
    assert sum(n for n in sizes if n <= _CHUNK) == len(frames)
    whole = apply(frames, found.transforms, field=found.field)
    assert found.blinks == find_blinks(whole, stabilizer.mouth_box)
    some = np.linspace(0, len(frames) - 1, 100).round().astype(int)
    np.testing.assert_array_equal(found.steady, np.median(whole[some], axis=0).astype(np.uint8))


class _Readings:
    """Frames made again at each reading, as :class:`StreamedCrops` are: ``len()`` and
    iteration only (indexing fails), the readings counted and how far each went."""

    def __init__(self, frames: np.ndarray) -> None:
        self.frames, self.read = frames, []

    def __len__(self) -> int:
        return len(self.frames)

    def __iter__(self):
        self.read.append(0)
        for frame in self.frames:
            self.read[-1] += 1
            yield frame.copy()


def test_registration_reads_frames_made_again_in_order_with_the_arrays_result(person):
    """Issue 50: a face-crop model's dub held every 256-px crop (0.2 MB a frame) while it
    registered them. Registration now reads its frames in order: once up to the first usable
    frame, once to register, once to stabilize, with the result of the held array."""
    from miketalk.composite.registration import register_video

    frames, _ = _clip(120)
    stabilizer = Model(person).stabilizer()
    usable = np.ones(len(frames), bool)
    usable[:3] = False  # the first usable frame is read up to, not indexed
    held = register_video(frames, 25.0, stabilizer, usable=usable, refine=True, shots=None)
    readings = _Readings(frames)
    streamed = register_video(readings, 25.0, stabilizer, usable=usable, refine=True)
    assert readings.read == [4, len(frames), len(frames)]
    np.testing.assert_array_equal(streamed.transforms, held.transforms)
    np.testing.assert_array_equal(streamed.field, held.field)
    assert streamed.blinks == held.blinks
    np.testing.assert_array_equal(streamed.steady, held.steady)


def test_a_face_crop_videos_crops_made_again_are_the_held_crops_byte_for_byte() -> None:
    from miketalk.track.crop import FaceCropSettings
    from miketalk.track.video_crops import StreamedCrops, crop_video

    clip = Path(__file__).parents[2] / "data" / "grid_s1" / "video" / "bbaf2n.mpg"
    settings = FaceCropSettings()
    held = crop_video(clip, crop=settings, frames=30)
    streamed = crop_video(clip, crop=settings, frames=30, hold=False)
    assert isinstance(streamed.crops, StreamedCrops) and len(streamed) == 30
    assert streamed.crops.shape == held.crops.shape
    for _ in range(2):  # each reading decodes the video again, to the same bytes
        np.testing.assert_array_equal(np.stack(list(streamed.crops)), held.crops)
    np.testing.assert_array_equal(streamed.to_crop, held.to_crop)


@pytest.mark.parametrize("budget", ["default", "none"])
def test_a_short_videos_crops_are_read_once_and_held_a_long_ones_streamed(budget, monkeypatch):
    """Registration reads a video's crops twice: a short video's (at most
    :data:`~miketalk.composite.tracked.HOLD_CROPS_BYTES`) are read once into an array, the
    bytes of every reading; a longer one's are made again at each reading."""
    from miketalk.composite import registration, tracked
    from miketalk.track.crop import FaceCropSettings
    from miketalk.track.video_crops import StreamedCrops, crop_video

    clip = Path(__file__).parents[2] / "data" / "grid_s1" / "video" / "bbaf2n.mpg"
    if budget == "none":
        monkeypatch.setattr(tracked, "HOLD_CROPS_BYTES", 0)
    given = []

    def register(frames, *args, **kwargs):
        given.append(frames)
        raise KeyboardInterrupt  # what registration was given is all this asks

    monkeypatch.setattr(registration, "register_video", register)
    with pytest.raises(KeyboardInterrupt):
        tracked.tracked_background(clip, None, FaceCropSettings(), frames=30)
    (frames,) = given
    held = crop_video(clip, crop=FaceCropSettings(), frames=30).crops
    if budget == "none":
        assert isinstance(frames, StreamedCrops)
        frames = np.stack(list(frames))
    assert isinstance(frames, np.ndarray) and frames.dtype == np.uint8
    np.testing.assert_array_equal(frames, held)


def test_the_eye_bands_are_held_in_half_the_bytes_with_the_same_blinks() -> None:
    """The eye band of every frame is what registration still holds for the whole video:
    as the exact sum of the three channels (uint16), the band times 3, with the blinks of
    the band in float."""
    from miketalk.composite.blinks import _blinks_of, _blinks_of_sums, _eye_sums, eye_band

    rng = np.random.default_rng(0)
    box = (92, 164, 72, 28)
    for n in (8, 130):
        frames = rng.integers(100, 140, (n, 256, 256, 3), dtype=np.uint8)
        frames[n // 3 : n // 3 + 2, 60:110] = 10  # eyes closed in two frames
        band, sums = eye_band(frames, box), _eye_sums(frames, box)
        assert sums.dtype == np.uint16
        np.testing.assert_array_equal(sums.astype(np.float32) / 3, band)
        assert _blinks_of_sums(sums) == _blinks_of(band) == (n // 3, n // 3 + 1)


def test_a_long_videos_eye_bands_are_held_a_block_at_a_time(monkeypatch) -> None:
    """Issue 50: the eye bands grew about 22 MB a minute of a face-crop dub. They are now held
    a block at a time, each block against its own usual eyes: up to a block, the whole
    video's blinks as before; longer, the blinks of every block, and never more held."""
    from miketalk.composite import blinks as eyes_of
    from miketalk.composite.blinks import _blinks_of_changes, _blinks_of_sums, _eye_sums

    monkeypatch.setattr(eyes_of, "BLINK_BLOCK", 40)
    rng = np.random.default_rng(1)
    box = (92, 164, 72, 28)
    closed = (5, 50, 51, 97, 125)
    for n, light in ((37, 0), (130, 0), (130, 30)):
        frames = rng.integers(115, 125, (n, 256, 256, 3), dtype=np.uint8)
        frames[98:, 60:110] += np.uint8(light)  # the light changes where the last block starts
        blinks = tuple(i for i in closed if i < n)
        frames[list(blinks), 60:110] = 10
        eyes = eyes_of._EyeChanges(n)
        for start in range(0, n, 7):  # given in pieces that straddle the blocks' ends
            eyes.add(_eye_sums(frames[start : start + 7], box))
        changes = eyes.changes()
        assert len(changes) == n and eyes.most_held <= 40
        assert _blinks_of_changes(changes) == blinks
        if n <= 40:
            assert _blinks_of_changes(changes) == _blinks_of_sums(_eye_sums(frames, box))
    # a whole video's median counts the changed light's frames as blinks; the blocks do not
    assert len(_blinks_of_sums(_eye_sums(frames, box))) > len(blinks)
