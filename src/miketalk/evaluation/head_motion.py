"""Does ``say --background auto`` move the head as the source frames do?

``python -m miketalk.evaluation.head_motion MODEL_DIR VIDEO.mp4``: the nose is
tracked (:func:`miketalk.evaluation.dubbing.nose_positions`, independent of the
stabilization) in the model's background frames and in the video ``say``
made; prints the standard deviation of its position in each, their ratio
(the issue's target: within 20 %), and the largest frame-to-frame step in each
(a loop that jumps would show as a step larger than the source's).
"""

from __future__ import annotations

import argparse

import numpy as np


def head_motion(model_dir: str, video: str) -> dict:
    """The nose's spread and largest step in the background frames and in ``video``."""
    from miketalk.evaluation.dubbing import nose_positions
    from miketalk.media.decode import read_video
    from miketalk.media.images import read_image
    from miketalk.talk.background_files import (
        DIRECTORY,
        REFERENCE,
        mouth_box_of,
        read_background,
    )

    reference = read_image(f"{model_dir}/{DIRECTORY}/{REFERENCE}")
    box = mouth_box_of(model_dir)
    background = read_background(model_dir)
    frames, _ = read_video(video)
    out = {}
    for name, seq in (("source", background.frames), ("output", frames)):
        nose = nose_positions(seq, reference, box)
        step = np.sqrt((np.diff(nose, axis=0) ** 2).sum(axis=1))
        out[name] = {
            "frames": len(seq),
            "sd_x": float(nose[:, 0].std()),
            "sd_y": float(nose[:, 1].std()),
            "largest_step": float(step.max()),
        }
    out["ratio_x"] = out["output"]["sd_x"] / out["source"]["sd_x"]
    out["ratio_y"] = out["output"]["sd_y"] / out["source"]["sd_y"]
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
