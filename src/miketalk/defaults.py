"""The one home of default settings and default paths.

Every other module, the CLI, the benchmarks and the workflow's ``common.smk``
take these from here; ``config.yaml`` sets an experiment's own values.

The results tree (``results/`` under the working directory)::

    results/corpus/<face>/      the recording: frames/, audio.wav, tables
    results/visemes/<face>/     the viseme images and their table
    results/flows/<face>/       flow databases, by method and strategy
    results/model/<face>/       the talking-face model (what ``miketalk say`` reads)
    results/truth/<face>/       ground truth of the synthetic face
    results/metrics/            tidy tables
    results/figures/            figures
"""

from __future__ import annotations

from pathlib import Path

#: Frame rate of rendered video, frames per second.
FPS = 30.0

#: Largest flow displacement a transition may move per frame before it is
#: oversampled (paper §7: 2.5-3.0 px).
MAX_PX_PER_FRAME = 2.5

#: The face whose model ``miketalk say`` uses when none is given.
FACE = "synthetic"

#: Root of every workflow output.
RESULTS = Path("results")


def corpus_dir(face: str = FACE, *, root: Path = RESULTS) -> Path:
    """``results/corpus/<face>``: the recording in the corpus folder format."""
    return root / "corpus" / face


def visemes_dir(face: str = FACE, *, root: Path = RESULTS) -> Path:
    """``results/visemes/<face>``: the viseme images and ``visemes.tsv``."""
    return root / "visemes" / face


def flows_dir(face: str = FACE, *, root: Path = RESULTS) -> Path:
    """``results/flows/<face>``: flow databases as ``<method>/<strategy>/``."""
    return root / "flows" / face


def model_dir(face: str = FACE, *, root: Path = RESULTS) -> Path:
    """``results/model/<face>``: the talking-face model."""
    return root / "model" / face


def truth_dir(face: str = FACE, *, root: Path = RESULTS) -> Path:
    """``results/truth/<face>``: the synthetic face's true flows and mouth mask."""
    return root / "truth" / face


def metrics_dir(*, root: Path = RESULTS) -> Path:
    """``results/metrics``: tidy tables."""
    return root / "metrics"


def figures_dir(*, root: Path = RESULTS) -> Path:
    """``results/figures``."""
    return root / "figures"


#: The background ``say`` plays under the mouth: ``"auto"`` (a model built from clips
#: plays its person's own frames, any other model is still), ``"still"`` (the model's
#: reference image, the paper's output) or the path of a video of the person.
BACKGROUND = "auto"

#: The region a synthesized mouth is blended into a frame over, in mouth widths about
#: the mouth box's centre (:func:`miketalk.composite.compositor.blend_mask`): half its width,
#: how far above the centre it starts (below the nose) and how far below it ends (past
#: the chin), half the width of its lower half, and the feathered edge's Gaussian sigma.
BLEND_HALF_WIDTH = 1.15
BLEND_ABOVE = 0.42
BLEND_BELOW = 1.0
BLEND_CHIN_WIDTH = 0.7
BLEND_FEATHER = 0.1

#: Warp the frame's lower face about the blend to follow the synthesized jaw
#: (:func:`miketalk.composite.follow.follow_render`), so its jaw line does not show twice.
BLEND_FOLLOW = True

#: How a face-crop model's compositor warps the frame's jaw
#: (:func:`miketalk.composite.for_model.model_compositor`): ``"on"`` (as
#: :data:`BLEND_FOLLOW`: up to half a mouth width beyond the blend mask), ``"face"`` (held
#: inside the crop's keep, its jaw ellipse and skin: ``Compositor(follow_within=...)``) or
#: ``"off"``. A crop model's mask stops at the jaw line, so ``"on"`` bends a textured room
#: beside the jaw (docs/dub.md, "The crop dub's ceiling, and the jaw's warp held off the room":
#: 476 pixels a frame moved by more than 8 levels outside the mask on the 30 hard clips, none
#: ``"off"``, with amplitude, r and LMD unchanged within their intervals and the worst seam
#: ratio 1.024 against 1.147).
BLEND_FOLLOW_CROP = "off"

#: How a render is sampled into a frame of the person (the compositor): ``"cubic"``
#: (bicubic) or ``"linear"`` (bilinear). A dubbed mouth is resampled twice before anyone sees
#: it (the corpus's stabilization made the render, the frame's transform places it), and
#: bilinear sampling at a fraction of a pixel averages neighbours. The bench's 40 held-out
#: clips dubbed with their own audio (``trained_heard``), cubic against linear, paired by clip:
#: the mouth's sharpness ratio 0.646 against 0.526 (+0.120, sd 0.012), the seam's gradient
#: ratio 0.972 against 0.955, inner-lip opening r +0.004 (sd 0.029), amplitude +0.031, mouth
#: LMD +0.001 px, mouth PSNR -0.12 dB (what a crisper picture costs in PSNR). A perfect mouth
#: (the clips' own frames dubbed back) keeps 0.77 of its sharpness through cubic, 0.63 linear.
BLEND_INTERPOLATION = "cubic"

#: How a mouth's colour is matched to the frames it is pasted into
#: (:mod:`miketalk.composite.colour`): ``"lips"`` (over the whole blend, from the model's rest
#: image to the background's median), ``"offset"`` (an additive offset learned on the blend's
#: edge: the skin) or ``"gain"`` (a per-channel gain learned there). On the 6 weekly addresses
#: held out, dubbed with their own recordings (docs/anyone.md, "The mouth's colour"), the lips'
#: CIELAB distance from his own, paired with ``"offset"``: ``"lips"`` 6.22 -> 3.47 (5 of 6
#: nearer; wa05 13.3 -> 4.4), ``"gain"`` 6.22 -> 6.44 (2 of 6); r, amplitude and LMD within
#: 0.05 of ``"offset"``'s for both.
BLEND_COLOUR = "lips"

#: How the trained face brings each clip's patches to the light of the face they are drawn
#: onto (:mod:`miketalk.draw.trained.light`): ``"session"`` (a CIELAB shift per clip, learned
#: on the lower face between the face and the clip's frames of the same mouth shape) or
#: ``"border"`` (an RGB offset per clip from the patch's border band, the way before). On the 8
#: weekly addresses held out, dubbed by the trained face hearing their own recordings
#: (docs/anyone.md, "The trained face's patches"), paired with ``"border"``: the lips' CIELAB
#: distance from his 4.43 -> 2.70 (8 of 8 nearer), its spread over a clip's frames 1.97 ->
#: 1.25 (8 of 8 steadier); opening r +0.02, amplitude +0.00, LMD -0.00 px. On s1's 40
#: held-out sentences (8-clip model): mouth PSNR +0.69 dB (39 of 40), opening r -0.004.
PATCH_LIGHT = "session"

#: How a face built from clips brings the viseme images the paper's morph draws to the light
#: of its face (:mod:`miketalk.draw.trained.light`,
#: :func:`~miketalk.draw.trained.light.lit_visemes`): ``"session"`` (each image's clip's CIELAB
#: shift, the trained face's patches') or ``"built"`` (as the build cut them, each in its own
#: day's light). On the 8 weekly addresses held out (docs/anyone.md, "The morph's viseme
#: images"), paired with ``"built"``: the morph's lips' CIELAB distance from his 2.73 -> 2.33
#: (6 of 8 nearer); opening r, amplitude and LMD within 0.04. On s1's 40 held-out sentences:
#: opening r +0.013. The learned coarticulation draws the images as built: lit, its lips came
#: no nearer (2.52 -> 2.59) and s1's one-video model's amplitude moved 0.1.
VISEME_LIGHT = "session"

#: Keep the blend off the reference's backdrop and clothes
#: (:func:`miketalk.composite.follow.skin_weight`): the render's collar beside the jaw.
BLEND_SKIN = True

#: Seconds of the person's own frames a model built from clips keeps as the background
#: ``say`` plays (:mod:`miketalk.composite.background`): at most ``BACKGROUND_SECONDS``, at least
#: ``BACKGROUND_SHORTEST``, cut where the head stands still (the ping-pong loop's turns).
BACKGROUND_SECONDS = 3.0
BACKGROUND_SHORTEST = 2.0

#: Gaussian sigma, seconds, of the smoothing in time of a video's stabilization transforms
#: before the mouth is composited by them
#: (:func:`miketalk.composite.background.background_from_video`):
#: each frame's registration has its own error, which slides the mouth against the nose. On
#: s1's held-out clips 0.04 s (one frame at 25 fps) halves the nose's frame-to-frame motion in
#: the stabilized frames (lbbk4n 0.34 to 0.18 px, prbdzn 0.31 to 0.18); 0 keeps them raw.
BACKGROUND_SMOOTH = 0.04

#: The flows of a model ``miketalk build`` makes: the workflow's defaults of
#: ``flow.methods.bergen``, ``flow.strategy`` and ``flow.mixed_window``
#: (workflow/schemas/config.schema.yaml; tests/product/test_build.py checks they agree).
BUILD_FLOW_METHOD = {"estimator": "bergen", "settings": {"levels": 5}}
BUILD_FLOW_STRATEGY = "bridge"
BUILD_MIXED_WINDOW = 6

#: Seconds at the end of the video ``miketalk build`` holds out (0: none).
HELDOUT_SECONDS = 0.0
