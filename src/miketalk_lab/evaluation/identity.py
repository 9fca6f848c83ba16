"""The face-identity distances that set :data:`miketalk.track.identity.MAX_DISTANCE`.

``python -m miketalk_lab.evaluation.identity REFERENCE VIDEO... [--mirror]``: the product's
own measure (:func:`miketalk.track.identity.face_descriptor`, dlib's face-recognition ResNet
on the tracker's 5 landmarks) of the face of ``REFERENCE`` (a model folder, whose
``background/reference.png`` is read, or an image or video, whose first frame, or the frame at
``--at`` seconds, is taken) against each video's faces at 7 frames spread over it, as
:func:`~miketalk.track.identity.person_distance` takes them; ``--mirror`` flips each frame
left to right first. Prints one line per video (the median distance) and the least, median
and largest over them.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def _reference(where: Path, at: float) -> np.ndarray:
    from miketalk.media.decode import read_video
    from miketalk.media.images import read_image

    if where.is_dir():  # a model: its tracker reference
        from miketalk.model.face import open_model

        with open_model(where) as model:
            return model.reference
    if where.suffix.lower() in (".png", ".jpg", ".jpeg"):
        return read_image(where)
    return read_video(where, start=at or None, frames=1)[0][0]


def video_distance(model: np.ndarray, video: Path, *, mirror: bool = False) -> float | None:
    """The median descriptor distance of ``video``'s faces (7 frames) to ``model``'s."""
    from miketalk.errors import MiketalkError
    from miketalk.media.decode import read_video, stated_seconds
    from miketalk.stabilize.faces import SAMPLES
    from miketalk.track.identity import face_descriptor

    duration = stated_seconds(video) or 0.0
    distances = []
    for t in (np.arange(SAMPLES) + 0.5) * duration / SAMPLES:
        try:
            frame = read_video(video, start=float(t), frames=1)[0][0]
        except MiketalkError:
            break
        found = face_descriptor(np.ascontiguousarray(frame[:, ::-1]) if mirror else frame)
        if found is not None:
            distances.append(float(np.linalg.norm(found - model)))
    return float(np.median(distances)) if distances else None


def main(argv: list[str] | None = None) -> int:
    """Print the distances (see the module docstring)."""
    from miketalk.track.identity import face_descriptor

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[1])
    parser.add_argument("reference", type=Path)
    parser.add_argument("videos", type=Path, nargs="+")
    parser.add_argument("--mirror", action="store_true")
    parser.add_argument("--at", type=float, default=0.0, help="the reference video's second")
    args = parser.parse_args(argv)
    model = face_descriptor(_reference(args.reference, args.at))
    if model is None:
        print(f"no face in the reference {args.reference}")
        return 1
    found = []
    for video in args.videos:
        distance = video_distance(model, video, mirror=args.mirror)
        print(f"{video.stem}: {'no face' if distance is None else f'{distance:.3f}'}", flush=True)
        if distance is not None:
            found.append(distance)
    if found:
        print(f"{len(found)} videos: {min(found):.3f} / {np.median(found):.3f} / {max(found):.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
