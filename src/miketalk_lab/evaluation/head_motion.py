"""Does ``say --background auto`` move the head and blink as the source frames do?

``python -m miketalk_lab.evaluation.head_motion MODEL_DIR VIDEO.mp4``: dlib's landmarks
(:mod:`miketalk_lab.evaluation.landmarks`) are marked on the model's background frames (the
source) and on the video ``say`` made, each from the face box of its own median frame.
Prints, for each, the standard deviation of the nose's position (the centroid of the
nose tip and the nostrils' base, :data:`~miketalk_lab.evaluation.landmarks.NOSE`) and its
largest frame-to-frame step (a loop that jumps would show as a step larger than the
source's), the ratio of the output's to the source's standard deviation (the issue's
target: within 20 %), and the eyes: the eye aspect ratio
(:func:`~miketalk_lab.evaluation.landmarks.eye_openness`) of each output frame against that
of the background frame it shows (their correlation), and the frames where the eyes
close (below :data:`CLOSED` of the sequence's median) in the background, where the output
should show them, and where it does.
"""

from __future__ import annotations

import argparse

import numpy as np

#: Eyes count as closed below this fraction of the sequence's median eye aspect ratio.
CLOSED = 0.75


def _marks(frames: np.ndarray) -> np.ndarray:
    from miketalk_lab.evaluation.landmarks import face_landmarks

    landmarks = face_landmarks()
    return landmarks.points(frames, landmarks.face_box(frames))


def _closed(openness: np.ndarray) -> np.ndarray:
    return np.flatnonzero(openness < CLOSED * np.median(openness))


def head_motion(model_dir: str, video: str) -> dict:
    """The nose's spread and largest step, and the blinks, of the background and ``video``."""
    from miketalk.media.decode import read_video
    from miketalk.model.face import open_model
    from miketalk_lab.evaluation.landmarks import NOSE, eye_openness

    with open_model(model_dir) as model:
        background = model.background()
    frames, fps = read_video(video)
    out = {}
    eyes = {}
    for name, seq in (("source", background.frames), ("output", frames)):
        points = _marks(seq)
        nose = points[:, NOSE].mean(axis=1)
        step = np.sqrt((np.diff(nose, axis=0) ** 2).sum(axis=1))
        eyes[name] = eye_openness(points)
        out[name] = {
            "frames": len(seq),
            "nose_sd_x": float(nose[:, 0].std()),
            "nose_sd_y": float(nose[:, 1].std()),
            "largest_step": float(step.max()) if len(step) else 0.0,
            "closed_eyes": [int(i) for i in _closed(eyes[name])],
        }
    shown = np.array([background.index(k, fps) for k in range(len(frames))])
    expected = eyes["source"][shown]
    closed_source = set(out["source"]["closed_eyes"])
    out["output"]["closed_eyes_expected"] = [
        k for k, i in enumerate(shown) if int(i) in closed_source
    ]
    out["eye_correlation"] = float(np.corrcoef(expected, eyes["output"])[0, 1])
    for axis in ("x", "y"):
        out[f"ratio_{axis}"] = out["output"][f"nose_sd_{axis}"] / out["source"][f"nose_sd_{axis}"]
    return out


def main(argv: list[str] | None = None) -> int:
    """Command line (see the module docstring)."""
    import json

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("model")
    parser.add_argument("video")
    args = parser.parse_args(argv)
    print(json.dumps(head_motion(args.model, args.video), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
