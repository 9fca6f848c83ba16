"""The face tracker: a stream of frames in, a :class:`Track` out.

Per frame (:meth:`FaceTracker.update`):

1. **Shot change.** A grey thumbnail of the frame (every ``W // 64``-th pixel)
   is compared with the previous frame's; a mean absolute difference above
   ``cut_threshold`` grey levels is a cut: the track ends there and the face is
   detected afresh.
2. **Detection** (on the first frame, after a failure or a cut, and every
   ``detect_every`` frames): dlib's frontal face detector on the frame
   area-resized so that the face is about ``detect_face_size`` pixels wide (before
   a face is known, or after a cut, so that the frame is ``detect_height`` pixels high,
   then twice that if nothing is found). Faces smaller than ``min_face_ratio`` times the
   largest are ignored (a face on a poster behind the speaker); two or more faces
   left fail the frame ("several faces"); none fails it ("no frontal face") unless a
   face is being tracked (the check of step 4 then decides). A detection that does
   not agree with the tracked face (its centre a quarter of its size away, or its
   size off by a third) restarts the track from the detection.
3. **Landmarks** (:func:`~miketalk.track.detect.aligned_landmarks`): the 5-point
   predictor on an upright patch placed by the previous frame's transform (or the
   detector's box), then again on the patch placed by that first fit (``passes``);
   the frame's transform is the least-squares similarity from the landmarks to the
   canonical ones (:mod:`~miketalk.track.canonical`).
4. **Checks**: the landmarks' RMS distance from the fitted canonical ones
   (``max_fit_error`` eye distances: a profile, a face half out of the frame, an
   occlusion), the last pass's change (``max_change``: the predictor did not
   settle), and the detector on the patch (``min_face_score``: a frontal face is
   where the landmarks are). A tracked frame failing them is detected afresh once;
   failing again, it is reported and left out.
5. **Jumps**: a tracked frame whose face points are more than ``max_step`` eye
   distances from the previous frame's starts a new segment (a cut the thumbnail
   missed: a jump cut, the same framing of another take).

Then (:meth:`FaceTracker.finish`) the transforms are smoothed within each segment
(:mod:`~miketalk.track.smooth`: glitches replaced, then local quadratics of Gaussian
widths up to ``smooth_seconds``, the widest that agrees with the narrower ones within
``smooth_gamma`` standard deviations).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.media.decode import iter_video_frames, video_info
from miketalk.track.canonical import CANONICAL_BOX, CANONICAL_LANDMARKS
from miketalk.track.detect import (
    FaceBox,
    aligned_landmarks,
    box_transform,
    detect_faces,
    face_window,
    patch_face_score,
)
from miketalk.track.result import Failure, FailureRange, Track
from miketalk.track.similarity import apply_affine, fit_similarity, invert_affine
from miketalk.track.smooth import smooth_transforms

__all__ = [
    "FaceTracker",
    "Failure",
    "FailureRange",
    "Track",
    "TrackerSettings",
    "track_frames",
    "track_video",
]

_THUMB_COLUMNS = 64  # the shot-change thumbnail's width, about


@dataclass(frozen=True)
class TrackerSettings:
    """How the tracker works (see :mod:`miketalk.track.track` for each step)."""

    #: Frames between full-frame detections while a face is tracked.
    detect_every: int = 15
    #: The face box's side, in pixels, at which the detector runs once a face is known.
    detect_face_size: float = 110.0
    #: The frame's height, in pixels, at which the detector first looks (then twice it).
    detect_height: int = 360
    #: Faces smaller than this fraction of the largest are ignored.
    min_face_ratio: float = 0.5
    #: Predictor passes per frame.
    passes: int = 2
    #: The landmarks' largest RMS distance from the canonical ones, in eye distances (on
    #: hard s1 and Obama's clips at most 0.077; a face squeezed to 0.65 of its width, as
    #: a head turned by about 50 degrees: 0.12).
    max_fit_error: float = 0.12
    #: The last pass's largest change of the face points, in eye distances.
    max_change: float = 0.1
    #: The patch detector's lowest score for a frontal face (hard s1 and Obama's clips:
    #: 1.0 and more; the eyes under a grey band: about 0; the mouth and nose under one:
    #: -0.5).
    min_face_score: float = 0.5
    #: A larger move of the face points from one frame to the next starts a new segment.
    max_step: float = 0.3
    #: A larger mean absolute thumbnail difference (grey levels) is a shot change.
    cut_threshold: float = 30.0
    #: The widest smoothing Gaussian's standard deviation, in seconds (0: no smoothing).
    smooth_seconds: float = 0.15
    #: The smoothing's confidence intervals, in standard deviations (smaller: follows
    #: fast moves more closely, removes less jitter).
    smooth_gamma: float = 1.0
    #: A glitch (:func:`~miketalk.track.smooth.smooth_poses`): this many times the
    #: segment's median distance from the neighbours' prediction...
    outlier_factor: float = 6.0
    #: ... and this many eye distances (GRID's clips hold real one-frame jolts of 0.05,
    #: seen alike at 360x288 and in hard s1: they are not glitches).
    min_outlier: float = 0.1

    def __post_init__(self) -> None:
        if self.detect_every < 1 or self.passes < 1:
            raise MiketalkError("detect_every and passes must be at least 1")
        positive = ("detect_face_size", "detect_height", "max_fit_error", "max_change",
                    "max_step", "cut_threshold", "smooth_gamma", "outlier_factor",
                    "min_outlier")  # fmt: skip
        bad = [name for name in positive if not getattr(self, name) > 0]
        if bad or not 0 < self.min_face_ratio <= 1 or self.smooth_seconds < 0:
            raise MiketalkError(f"tracker settings out of range: {', '.join(bad) or 'ratio'}")


@dataclass
class _State:
    """What the tracker carries from one frame to the next."""

    previous: np.ndarray | None = None  # the last frame's raw transform, if it was tracked
    since_detection: int = 0
    face_size: float | None = None  # the face box's side in frame pixels, once known
    thumbnail: np.ndarray | None = None
    new_segment: bool = True
    raw: list[np.ndarray] = field(default_factory=list)
    landmarks: list[np.ndarray] = field(default_factory=list)
    fit_error: list[float] = field(default_factory=list)
    face_score: list[float] = field(default_factory=list)
    reasons: list[Failure | None] = field(default_factory=list)
    starts: list[bool] = field(default_factory=list)


class FaceTracker:
    """Track one face through a stream of frames, one :meth:`update` per frame.

    Parameters
    ----------
    fps : float
        The frames' rate (for the smoothing's width in frames).
    settings : TrackerSettings, optional
        How it works (the defaults otherwise).
    """

    def __init__(self, *, fps: float, settings: TrackerSettings | None = None) -> None:
        if not (isinstance(fps, int | float) and math.isfinite(fps) and fps > 0):
            raise MiketalkError(f"fps must be a positive number, got {fps!r}")
        self.fps = float(fps)
        self.settings = settings or TrackerSettings()
        self._state = _State()
        self._size: tuple[int, int] | None = None

    def update(self, frame: np.ndarray) -> Failure | None:
        """Track the face in the next frame.

        Parameters
        ----------
        frame : numpy.ndarray
            ``(H, W, 3)`` uint8 RGB or ``(H, W)`` uint8 grey (the tracker works in grey:
            a grey stream costs ffmpeg a third of the bytes and no colour conversion),
            every frame of the stream the same size.

        Returns
        -------
        Failure or None
            Why the frame is left out, or None if it is tracked.

        Raises
        ------
        MiketalkError
            If the frame is not ``(H, W, 3)`` or ``(H, W)`` uint8 or its size changes.
        """
        frame = _check_frame(frame)
        size = (frame.shape[1], frame.shape[0])
        if self._size is None:
            self._size = size
        elif size != self._size:
            raise MiketalkError(f"frame {len(self._state.reasons)} is {size}, not {self._size}")
        state, s = self._state, self.settings
        if self._shot_changed(frame):
            state.previous = state.face_size = None  # another shot: another framing
            state.new_segment = True
        guess, detected = state.previous, False
        if guess is None or state.since_detection >= s.detect_every:
            faces = self._detect(frame)
            detected = True
            state.since_detection = 0
            if len(faces) > 1:
                return self._fail(Failure.SEVERAL_FACES)
            if faces and (guess is None or not _agrees(faces[0], guess)):
                guess = box_transform(faces[0])
            elif not faces and guess is None:
                return self._fail(Failure.NO_FACE)
        state.since_detection += 1
        assert guess is not None
        fit = self._fit(frame, guess)
        if isinstance(fit, Failure) and not detected:
            faces = self._detect(frame)
            state.since_detection = 1
            if len(faces) > 1:
                return self._fail(Failure.SEVERAL_FACES)
            if not faces:
                return self._fail(Failure.NO_FACE)
            fit = self._fit(frame, box_transform(faces[0]))
        if isinstance(fit, Failure):
            return self._fail(fit)
        transform, landmarks, error, score = fit
        if state.previous is not None and _step(state.previous, transform) > s.max_step:
            state.new_segment = True
        state.face_size = CANONICAL_BOX[2] / math.sqrt(abs(np.linalg.det(transform[:, :2])))
        self._record(transform, landmarks, error, score, None)
        state.previous = transform
        return None

    def finish(self) -> Track:
        """The track of every frame given so far, smoothed.

        Raises
        ------
        MiketalkError
            If no frame was given.
        """
        state, s = self._state, self.settings
        n = len(state.reasons)
        if n == 0 or self._size is None:
            raise MiketalkError("no frames to track")
        segments: list[tuple[int, int]] = []
        for i in range(n):
            if state.reasons[i] is not None:
                continue
            if state.starts[i] or not segments or segments[-1][1] != i:
                segments.append((i, i + 1))
            else:
                segments[-1] = (segments[-1][0], i + 1)
        raw = np.stack(state.raw)
        smoothed, outliers = smooth_transforms(
            raw,
            segments,
            sigma=s.smooth_seconds * self.fps,
            gamma=s.smooth_gamma,
            outlier_factor=s.outlier_factor,
            min_outlier=s.min_outlier,
        )
        return Track(
            transforms=smoothed,
            raw=raw,
            landmarks=np.stack(state.landmarks),
            fit_error=np.array(state.fit_error),
            face_score=np.array(state.face_score),
            reasons=tuple(state.reasons),
            segments=tuple(segments),
            outliers=outliers,
            fps=self.fps,
            size=self._size,
        )

    def _shot_changed(self, frame: np.ndarray) -> bool:
        """Whether the frame's thumbnail differs from the previous frame's by a cut's amount."""
        step = max(1, frame.shape[1] // _THUMB_COLUMNS)
        small = frame[step // 2 :: step, step // 2 :: step].astype(np.int16)
        if small.ndim == 3:
            small = (small[..., 0] * 2 + small[..., 1] * 5 + small[..., 2]) // 8
        thumbnail = small
        previous, self._state.thumbnail = self._state.thumbnail, thumbnail
        if previous is None:
            return False
        return float(np.abs(thumbnail - previous).mean()) > self.settings.cut_threshold

    def _detect(self, frame: np.ndarray) -> list[FaceBox]:
        """The frame's faces, the small ones beside the largest left out."""
        s, height = self.settings, frame.shape[0]
        if self._state.face_size is not None:
            scales = [s.detect_face_size / self._state.face_size]
        else:
            scales = [s.detect_height / height, 2 * s.detect_height / height]
        faces: list[FaceBox] = []
        for scale in scales:
            faces = detect_faces(frame, scale=scale)
            if faces or scale >= 1.0:
                break
        if not faces:
            return []
        largest = max(f.size for f in faces)
        return [f for f in faces if f.size >= s.min_face_ratio * largest]

    def _fit(
        self, frame: np.ndarray, guess: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, float, float] | Failure:
        """The landmarks and transform from ``guess``, or why they fail the checks."""
        s = self.settings
        transform, change = guess, math.inf
        landmarks = patch = None
        window = face_window(frame, guess)
        for _ in range(s.passes):
            landmarks, patch = aligned_landmarks(window, transform)
            fitted = fit_similarity(landmarks, CANONICAL_LANDMARKS)
            change = _step(transform, fitted)
            transform = fitted
        assert landmarks is not None and patch is not None
        residual = apply_affine(transform, landmarks) - CANONICAL_LANDMARKS
        error = float(np.sqrt((residual**2).sum(axis=1).mean()))
        if error > s.max_fit_error or (s.passes > 1 and change > s.max_change):
            return Failure.POOR_FIT
        score = patch_face_score(patch)
        if score < s.min_face_score:
            return Failure.NO_FACE
        return transform, landmarks, error, score

    def _fail(self, reason: Failure) -> Failure:
        state = self._state
        state.previous = None
        state.new_segment = True
        nan = np.full((2, 3), np.nan)
        self._record(nan, np.full((5, 2), np.nan), math.nan, -math.inf, reason)
        return reason

    def _record(
        self,
        transform: np.ndarray,
        landmarks: np.ndarray,
        error: float,
        score: float,
        reason: Failure | None,
    ) -> None:
        state = self._state
        state.raw.append(transform)
        state.landmarks.append(landmarks)
        state.fit_error.append(error)
        state.face_score.append(score)
        state.reasons.append(reason)
        state.starts.append(reason is None and state.new_segment)
        if reason is None:
            state.new_segment = False


def _check_frame(frame: np.ndarray) -> np.ndarray:
    frame = np.asarray(frame)
    if frame.dtype != np.uint8 or frame.shape[2:] not in ((), (3,)) or frame.ndim < 2:
        raise MiketalkError(
            f"a frame must be (H, W, 3) uint8 RGB or (H, W) grey, got {frame.shape} {frame.dtype}"
        )
    return np.ascontiguousarray(frame)


def _step(before: np.ndarray, after: np.ndarray) -> float:
    """How far the canonical face points move from one transform to another, in eye distances
    (of ``before``)."""
    a = apply_affine(invert_affine(before), CANONICAL_LANDMARKS)
    b = apply_affine(invert_affine(after), CANONICAL_LANDMARKS)
    eye_distance = 1.0 / math.sqrt(abs(np.linalg.det(before[:, :2])))
    return float(np.sqrt(((a - b) ** 2).sum(axis=1)).max() / eye_distance)


def _agrees(face: FaceBox, transform: np.ndarray) -> bool:
    """Whether a detector box is where the tracked face's box is."""
    cu, cv, side = CANONICAL_BOX
    centre = apply_affine(invert_affine(transform), np.array([cu, cv]))
    size = side / math.sqrt(abs(np.linalg.det(transform[:, :2])))
    close = math.hypot(face.x - centre[0], face.y - centre[1]) < 0.25 * size
    return close and 0.75 < face.size / size < 1.0 / 0.75


def track_frames(
    frames: Iterable[np.ndarray], *, fps: float, settings: TrackerSettings | None = None
) -> Track:
    """Track the face through frames (an array or any iterable, consumed once).

    Parameters
    ----------
    frames : iterable of numpy.ndarray
        ``(H, W, 3)`` uint8 RGB or ``(H, W)`` grey frames, or one array of them.
    fps : float
        Their rate.
    settings : TrackerSettings, optional
        How the tracker works.

    Returns
    -------
    Track
    """
    tracker = FaceTracker(fps=fps, settings=settings)
    for frame in frames:
        tracker.update(frame)
    return tracker.finish()


def track_video(
    path: str | os.PathLike[str],
    *,
    settings: TrackerSettings | None = None,
    start: float | None = None,
    frames: int | None = None,
) -> Track:
    """Track the face through a video file, streaming its frames (memory of one frame), grey
    (:func:`~miketalk.media.decode.iter_video_frames`: the tracker needs no colour).

    Parameters
    ----------
    path : str or os.PathLike
        Any video ffmpeg reads.
    settings : TrackerSettings, optional
        How the tracker works.
    start : float, optional
        Seconds from the beginning.
    frames : int, optional
        At most this many frames.

    Returns
    -------
    Track
    """
    _, _, fps = video_info(path)
    return track_frames(
        iter_video_frames(path, start=start, frames=frames, grey=True), fps=fps, settings=settings
    )
