"""A synthetic talking face whose true motion is known: the test harness of miketalk.

``Face`` is the parametric face: a textured mesh of the lower face (skin and lips on an
elliptic grid densest at the mouth, upper and lower teeth, tongue, dark mouth cavity) that
deforms by a linear blendshape model over nine mouth parameters, with a pose for every
corpus target. ``FaceRenderer`` renders it off-screen (pyvista/VTK, no anti-aliasing,
byte-identical across runs and processes), computes the true flow between two poses with
its validity mask, and the mouth mask used by the metrics::

    from synth_face import Face, FaceRenderer
    face = Face()
    with FaceRenderer(face, size=256) as r:
        image = r.render(face.target("aa"))
        flow, valid = r.true_flow(face.target("#"), face.target("aa"))

How the true flow is checked (``tests/test_synth_face.py``, ``miketalk_lab.bench.synth_face``):
a rigid rotation of the face about the camera centre gives exactly the analytic homography
and a rigid translation ``f t / depth``; B warped back along the flow reproduces A up to
resampling noise (and shading, in the lit renders), with the residual smallest at zero
flow offset (the flow is aligned with VTK's pixels); the renderer's and our rasteriser's
silhouettes agree pixel for pixel; teeth, tongue and cavity of an open mouth are invalid
once it closes.

Modules: ``skin``, ``mouth``, ``dental`` (geometry), ``textures``, ``blendshapes``,
``targets`` (the pose table), ``face``, ``camera``, ``raster``, ``flow`` (true flow),
``mask``, ``render``, ``validate`` (warp-back checks), ``sheet`` (contact sheet).
"""

from synth_face.face import Face
from synth_face.render import FaceRenderer

__all__ = ["Face", "FaceRenderer"]
