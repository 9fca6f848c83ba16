"""Benchmark of the synthetic face: render speed, true-flow speed and true-flow accuracy.

``run(out_dir)`` measures, on the whole machine (the renderer is Mesa's llvmpipe, which
uses every core):

- render frames per second at 256² and 512² (a jaw-opening sweep, vertices and normals
  updated every frame, image read back);
- seconds per true flow at 256² and 512²;
- the true flow of a rigid rotation of the face about the camera centre against its exact
  homography (max error, pixels) and of a rigid translation against ``f t / depth``;
- the warp-back residual: the render of B backward-warped along the true flow, against the
  render of A (mean absolute grey levels over the valid region, eroded by 1 px), for the
  rigid case and for pairs of corpus targets, with the no-warp difference for scale, and
  again with ``lighting="albedo"`` (texture only: what is left is resampling noise);
- the alignment of the true flow with the renderer: the constant flow offset that
  minimises the rigid warp-back residual (pixels; 0 when they agree).

Run it with ``python -m miketalk_lab.bench.synth_face --out DIR``; it writes only the small
``synth_face.json``.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import time

import numpy as np

from miketalk import defaults
from miketalk.media.atomic import write_text_atomic
from miketalk.visemes import viseme_slug

#: Target pairs whose warp-back residual is measured (A, B).
PAIRS: tuple[tuple[str, str], ...] = (
    ("#", "aa"),
    ("aa", "#"),
    ("k", "e"),
    ("#", "f"),
    ("ii", "uu"),
)
_SWEEP_FRAMES = 60


def _render_fps(renderer, p_a: np.ndarray, p_b: np.ndarray) -> float:
    renderer.render(p_a)
    start = time.perf_counter()
    for i in range(_SWEEP_FRAMES):
        a = i / (_SWEEP_FRAMES - 1)
        renderer.render((1 - a) * p_a + a * p_b)
    return _SWEEP_FRAMES / (time.perf_counter() - start)


def _flow_seconds(renderer, p_a: np.ndarray, p_b: np.ndarray, runs: int = 5) -> float:
    renderer.true_flow(p_a, p_b)
    start = time.perf_counter()
    for _ in range(runs):
        renderer.true_flow(p_a, p_b)
    return (time.perf_counter() - start) / runs


def run(out_dir: pathlib.Path) -> dict[str, float]:
    """Measure the synthetic face; print a table; write ``synth_face.json``.

    Parameters
    ----------
    out_dir : pathlib.Path
        Where ``synth_face.json`` goes (created if missing).

    Returns
    -------
    dict of str to float
        ``render_fps_256``, ``render_fps_512``, ``true_flow_seconds_256``,
        ``true_flow_seconds_512``, ``rigid_rotation_max_err_px``,
        ``rigid_translation_max_err_px``, ``rigid_warp_residual_grey``,
        ``rigid_warp_baseline_grey``, ``align_offset_x_px``, ``align_offset_y_px``, per pair
        ``warp_residual_grey_A_B`` / ``warp_baseline_grey_A_B`` / ``..._mouth_A_B``, and
        their means ``pairs_warp_residual_grey`` and ``pairs_warp_residual_mouth_grey``; the
        same in the mouth with ``lighting="albedo"`` (``albedo_warp_residual_mouth_grey_A_B``,
        ``pairs_albedo_warp_residual_mouth_grey``).
    """
    from synth_face import Face, FaceRenderer
    from synth_face.raster import rasterize
    from synth_face.validate import alignment_offset, warp_residual

    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    face = Face()
    closed, wide = face.target("#"), face.target("aa")
    figures: dict[str, float] = {}
    for size in (512, 256):
        with FaceRenderer(face, size) as r:
            figures[f"render_fps_{size}"] = _render_fps(r, closed, wide)
            figures[f"true_flow_seconds_{size}"] = _flow_seconds(r, closed, wide)

    with FaceRenderer(face, 256) as r:
        cam = r.camera
        # Rigid rotation about the camera centre: an exact, depth-free homography.
        rot = cam.rotation_about_center(0.4, -0.3)
        flow, valid = r.true_flow(closed, closed, rigid_b=rot)
        figures["rigid_rotation_max_err_px"] = float(
            np.abs(flow - cam.homography_flow(rot))[valid].max()
        )
        img_a, img_b = r.render(closed), r.render(closed, rigid=rot)
        res, base = warp_residual(img_a, img_b, flow, valid)
        figures["rigid_warp_residual_grey"], figures["rigid_warp_baseline_grey"] = res, base
        ox, oy = alignment_offset(img_a, img_b, flow, valid)
        figures["align_offset_x_px"], figures["align_offset_y_px"] = ox, oy
        # Rigid translation parallel to the image plane: f t / depth at every pixel.
        shift = np.eye(4)
        shift[:3, 3] = (1.5, -1.0, 0.0)
        flow, valid = r.true_flow(closed, closed, rigid_b=shift)
        depth = rasterize(cam.project(r.vertices(closed)), face.triangles, cam.size).depth
        expect = np.stack([1.5 * cam.focal_px / depth, 1.0 * cam.focal_px / depth], axis=-1)
        figures["rigid_translation_max_err_px"] = float(np.abs(flow - expect)[valid].max())

        mouth = r.mouth_mask()
        for ka, kb in PAIRS:
            pa, pb = face.target(ka), face.target(kb)
            flow, valid = r.true_flow(pa, pb)
            img_a, img_b = r.render(pa), r.render(pb)
            tag = f"{viseme_slug(ka)}_{viseme_slug(kb)}"
            res, base = warp_residual(img_a, img_b, flow, valid)
            figures[f"warp_residual_grey_{tag}"], figures[f"warp_baseline_grey_{tag}"] = res, base
            res, base = warp_residual(img_a, img_b, flow, valid, region=mouth)
            figures[f"warp_residual_mouth_grey_{tag}"] = res
            figures[f"warp_baseline_mouth_grey_{tag}"] = base
    # The same pairs in albedo mode: no shading, so only resampling noise should remain.
    with FaceRenderer(face, 256, lighting="albedo") as r:
        mouth = r.mouth_mask()
        for ka, kb in PAIRS:
            pa, pb = face.target(ka), face.target(kb)
            flow, valid = r.true_flow(pa, pb)
            img_a, img_b = r.render(pa), r.render(pb)
            tag = f"{viseme_slug(ka)}_{viseme_slug(kb)}"
            res, _ = warp_residual(img_a, img_b, flow, valid, region=mouth)
            figures[f"albedo_warp_residual_mouth_grey_{tag}"] = res
    tags = [f"{viseme_slug(a)}_{viseme_slug(b)}" for a, b in PAIRS]
    figures["pairs_warp_residual_grey"] = float(
        np.mean([figures[f"warp_residual_grey_{t}"] for t in tags])
    )
    figures["pairs_warp_residual_mouth_grey"] = float(
        np.mean([figures[f"warp_residual_mouth_grey_{t}"] for t in tags])
    )
    figures["pairs_albedo_warp_residual_mouth_grey"] = float(
        np.mean([figures[f"albedo_warp_residual_mouth_grey_{t}"] for t in tags])
    )
    _print_table(figures, tags)
    text = json.dumps(figures, indent=2, sort_keys=True) + "\n"
    write_text_atomic(out_dir / "synth_face.json", text)
    return figures


def _print_table(figures: dict[str, float], tags: list[str]) -> None:
    f = figures
    print("synthetic face (llvmpipe, all cores)")
    print(f"{'render fps 256² / 512²':<34} {f['render_fps_256']:8.1f} {f['render_fps_512']:8.1f}")
    print(
        f"{'true flow s 256² / 512²':<34} {f['true_flow_seconds_256']:8.3f} "
        f"{f['true_flow_seconds_512']:8.3f}"
    )
    print(f"{'rigid rotation max err (px)':<34} {f['rigid_rotation_max_err_px']:8.2e}")
    print(f"{'rigid translation max err (px)':<34} {f['rigid_translation_max_err_px']:8.2e}")
    print(
        f"{'rigid warp-back residual (grey)':<34} {f['rigid_warp_residual_grey']:8.2f}"
        f"   (no warp {f['rigid_warp_baseline_grey']:.2f})"
    )
    print(
        f"{'flow/render alignment dx, dy (px)':<34} {f['align_offset_x_px']:8.3f} "
        f"{f['align_offset_y_px']:8.3f}"
    )
    print("warp-back residual, mean |grey| over valid (eroded 1 px); mouth = also in mouth mask")
    print(
        f"{'pair':<10} {'residual':>9} {'no warp':>9} {'mouth res':>10} {'mouth no-warp':>14}"
        f" {'mouth albedo':>13}"
    )
    for t in tags:
        print(
            f"{t:<10} {f[f'warp_residual_grey_{t}']:9.2f} {f[f'warp_baseline_grey_{t}']:9.2f} "
            f"{f[f'warp_residual_mouth_grey_{t}']:10.2f} {f[f'warp_baseline_mouth_grey_{t}']:14.2f}"
            f" {f[f'albedo_warp_residual_mouth_grey_{t}']:13.2f}"
        )


def main() -> None:
    """``python -m miketalk_lab.bench.synth_face --out DIR``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out", type=pathlib.Path, default=defaults.RESULTS / "bench" / "synth_face"
    )
    run(parser.parse_args().out)


if __name__ == "__main__":
    main()
