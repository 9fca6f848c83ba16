"""Rendering: images made from a model's images and flows.

- :mod:`~miketalk.render.morph`: the paper's two-image morph (:class:`Morpher`,
  :func:`morph`) and the cross-dissolve baseline;
- :mod:`~miketalk.render.splat`: forward warping with a named collision rule and
  splat, and scanline hole filling;
- :mod:`~miketalk.render.multimorph`: the N-way morph of several visemes' weights;
- :mod:`~miketalk.render.kernels`: the C kernels behind the splat and blend;
- :mod:`~miketalk.composite.compositor`: a mouth rendered in the reference frame carried
  into a video frame and blended in.
"""

from miketalk.render.morph import Morpher, MorphStages, cross_dissolve, morph, morph_stages
from miketalk.render.splat import (
    HOLE_VALUE,
    MIN_SPLAT_WEIGHT,
    Collision,
    Splat,
    fill_holes_scanline,
    forward_warp,
)

__all__ = [
    "HOLE_VALUE",
    "MIN_SPLAT_WEIGHT",
    "Collision",
    "MorphStages",
    "Morpher",
    "Splat",
    "cross_dissolve",
    "fill_holes_scanline",
    "forward_warp",
    "morph",
    "morph_stages",
]
