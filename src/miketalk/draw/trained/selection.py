"""Trajectory-guided selection: the person's own frames along a predicted trajectory.

Wang et al. (2010): given the predicted description ``y_t`` of every output
frame, choose one training frame ``s_t`` for each by a Viterbi search
minimizing

.. math:: \\sum_t \\sum_d r_d (c_{s_t d} - y_{t d})^2 / \\bar v
          + w_j \\sum_t J(s_{t-1}, s_t)

where ``c`` are the training frames' descriptions, ``v`` the mean variance
of their components and ``r_d`` how much of component ``d`` the phones
predict (its cross-validated R^2 at fitting; a component the phones cannot
predict, such as what differs between recording sessions, does not steer the
choice) (the target cost, to which ``viseme`` adds a constant for a
training frame recorded while he showed another viseme than the output frame's:
the phones are known exactly where the trajectory is not, and a frame of the
same viseme carries what the components leave out, his teeth and tongue), and
the join cost ``J`` is
the visual distance between consecutive chosen frames (their descriptions and
the mean colour of their borders), nothing when ``s_t`` follows ``s_{t-1}`` in
the recording (the same frame or the next one or two of the same clip: the
recording is 25 fps, the video may be faster). Each output frame considers
its ``candidates`` nearest training frames.

:class:`PatchCompositor` draws frame ``s_t``'s colour patch onto the face with a
feathered mask (:func:`miketalk.draw.trained.mouths.feather_mask`), the patch
first brought to the face's light, clip by clip (its recording session:
:mod:`miketalk.draw.trained.light`). Where the selection
jumps (``s_t`` does not follow ``s_{t-1}``), the two frames about the jump are
blended with the frames that continue each side (``s_{t-1} + 1`` and
``s_t - 1`` in the recording), ``fade`` of the way on each side, so that no
frame changes all at once: by the project's optical-flow morph
(:class:`miketalk.render.morph.Morpher`, DIS flows between the two patches), as
Wang et al. smooth their joins, so that two mouths of different openings meet
half way instead of showing at once; or, with ``joins="dissolve"``, by a
cross-fade.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from miketalk import defaults
from miketalk.draw.trained.light import patch_light
from miketalk.draw.trained.mouths import MouthFrames, feather_mask
from miketalk.errors import MiketalkError


@dataclass(frozen=True)
class SelectionSettings:
    """The selection's weights (see the module docstring).

    Attributes
    ----------
    candidates : int
        Training frames considered per output frame.
    join : float
        Weight of the join cost against the target cost.
    colour : float
        Weight of the border colour difference (per grey level squared) in the join cost.
    continuation : int
        A frame that follows the previous one by up to this many recording frames joins free.
    fade : float
        How far the frames about a jump are blended towards each other's continuation.
    weighted : bool
        Weigh each component's target cost by how much of it the phones predict.
    amplitude : float
        How much of the trajectory's amplitude gain (real spread over predicted,
        :func:`miketalk.draw.trained.build.amplitude_gain`) the target gets: 0 none, 1 all,
        more to make up for what the selection's joins smooth away.
    gain_r2 : float
        A component whose cross-validated R^2 is under this gets that fraction of its gain
        (0: every component all of it).

    The defaults were chosen by 5-fold cross-validation on the training clips
    (``python -m miketalk_lab.bench.trained_cv``, on the bench's 40 and on its first 10;
    :data:`PREVIOUS_SELECTION` were the settings before): the gain measured on
    cross-validated predictions, given to every component the phones predict at
    all, with a stronger join, raised the opening's correlation and amplitude at
    both sizes for little mouth LMD or PSNR; larger gains reached more amplitude
    only by losing LMD and PSNR. ``fade`` was chosen the same way (the bench's 40
    training clips; the most opening correlation whose mouth PSNR and LMD stay within
    0.1 dB and 0.01 px of the fade before, 1/3): from the phones, 0.15 against 1/3
    raised the opening's correlation from 0.562 to 0.600 (PSNR -0.05 dB, LMD -0.001
    px), hearing the recording from 0.636 to 0.676 (PSNR -0.05 dB, LMD -0.001 px); no
    fade at all reached 0.605 and 0.682 for 0.14 and 0.16 dB of PSNR. A cross-fade
    between two mouths of different openings is a double exposure (a dissolve), which
    the landmarks measure as a wrong opening; the frames' steps stay under the real
    video's (99th percentile of the mouth's mean step 8.2 grey levels at 0.15, 7.9 at
    1/3, 10.4 in the real video).
    cv_gain : bool
        The gain from the cross-validated predictions (``amplitude_gain_cv``: each clip
        predicted without it, as a new sentence is) rather than from the fitted ones.
    lead : float
        Seconds ahead of each frame's time the trajectory is read (the mouth leads the sound).
    viseme : float
        Added to the target cost of a training frame whose viseme (from its clip's aligned
        phones) is not the output frame's; 0 (the default): none. In the cross-validation
        (``heard``, the bench's 40 training clips) 5 raised the opening's correlation by
        0.026 +- 0.014 (standard error) and the mouth width's by 0.046 +- 0.021 (from the
        phones alone, ``window``: 0.008 +- 0.023); 3 and 8, phones instead of visemes, or
        the neighbouring frames' visemes too did no better. On the bench's 40 held-out
        clips it did not hold: paired by clip, ``trained_heard``'s opening r +0.000 +-
        0.014 and first eigenlip r -0.031 +- 0.016; ``trained``'s +0.015 +- 0.013 and
        -0.028 +- 0.014. So it is off; ``render_trained(selection={"viseme": 5.0})`` and
        ``trained_cv``'s ``viseme=5`` switch it on for a face fitted since.
    joins : {"morph", "dissolve"}
        How the frames about a jump are blended (see the module docstring). The morph is
        what the specification asks for (Wang et al.'s joins); in the cross-validation on
        the bench's 40 training clips (``--morph '{"median": false, "splat": "bilinear"}'``,
        ``heard``, fade 0.15) it measured as the cross-fade did, within 0.002 on every
        measure paired by clip (opening r -0.001 +- 0.004 standard error, PSNR +0.001 dB),
        for 17 ms more per 75 frames; at larger fades the morph did not keep the opening
        either (1/3: r -0.026; 1/2: -0.060), so the fade stays 0.15.
    """

    candidates: int = 40
    join: float = 1.0
    colour: float = 0.02
    continuation: int = 2
    fade: float = 0.15
    weighted: bool = False
    amplitude: float = 1.0
    gain_r2: float = 0.05
    cv_gain: bool = True
    lead: float = 0.0
    joins: str = "morph"
    viseme: float = 0.0

    def to_dict(self) -> dict:
        """JSON-ready form."""
        return dict(self.__dict__)


#: The selection settings before cross-validation on the training clips chose the
#: defaults (``python -m miketalk_lab.bench.trained_cv``): the held-out evaluation's
#: ``trained_previous`` renders with them, for a paired comparison.
PREVIOUS_SELECTION = {
    "join": 0.3, "gain_r2": 0.25, "amplitude": 1.0, "cv_gain": False, "fade": 1.0 / 3.0,
    "joins": "dissolve",
}  # fmt: skip


def select(
    frames: MouthFrames,
    target: np.ndarray,
    settings: SelectionSettings,
    *,
    weights: np.ndarray | None = None,
    described: np.ndarray | None = None,
    visemes: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """The training frame chosen for each row of ``target`` ``(T, n)``: ``(T,)`` indices.

    ``weights`` (``(n,)``, default all 1) weigh the components in the target cost;
    ``described`` (``(N, n)``, default ``frames.coords``) are the training frames'
    descriptions the target cost compares with ``target``; ``visemes``, the output
    frames' ``(T,)`` and the training frames' ``(N,)`` viseme indices, add
    ``settings.viseme`` to the target cost where they differ.
    """
    coords = frames.coords if described is None else np.asarray(described, float)
    n_train = len(coords)
    target = np.asarray(target, float)
    if len(target) == 0:
        return np.zeros(0, np.int64)
    norm = float(frames.variance.mean())
    root = np.sqrt(np.ones(coords.shape[1]) if weights is None else np.asarray(weights, float))
    tw, cw = target * root, coords * root
    # target cost of every training frame for every output frame: (T, N), in place (the
    # expression's own operations, one array instead of four: 430 MB each for a 12-minute
    # recording and 3000 training frames)
    dist = 2.0 * tw @ cw.T
    np.subtract((tw**2).sum(axis=1)[:, None], dist, out=dist)
    dist += (cw**2).sum(axis=1)[None, :]
    dist /= norm
    k = min(settings.candidates, n_train)
    cand = np.empty((len(target), k), np.int64)
    for start in range(0, len(target), _BLOCK):  # the partition's indices a block at a time
        rows = slice(start, start + _BLOCK)
        if visemes is not None and settings.viseme > 0:
            shown, recorded = visemes
            dist[rows] += settings.viseme * (shown[rows, None] != recorded[None, :])
        cand[rows] = np.argpartition(dist[rows], k - 1, axis=1)[:, :k]
    cand = np.sort(cand, axis=1)  # deterministic order whatever the partition did
    cost_t = np.take_along_axis(dist, cand, axis=1)
    del dist
    continues = _continues_table(frames, settings.continuation)
    best = cost_t[0].copy()
    back = np.zeros((len(target), k), np.int64)
    for t in range(1, len(target)):
        prev, cur = cand[t - 1], cand[t]
        join = _join(frames, prev, cur, norm, settings.colour)
        step = cur[None, :] - prev[:, None]
        same_clip = frames.clip[prev][:, None] == frames.clip[cur][None, :]
        free = same_clip & (step >= 0) & (step <= settings.continuation)
        free &= continues[prev][:, None] >= step  # no clip boundary crossed
        total = best[:, None] + settings.join * np.where(free, 0.0, join)
        back[t] = np.argmin(total, axis=0)
        best = total[back[t], np.arange(k)] + cost_t[t]
    path = np.empty(len(target), np.int64)
    j = int(np.argmin(best))
    for t in range(len(target) - 1, -1, -1):
        path[t] = cand[t, j]
        j = int(back[t, j])
    return path


#: Output frames whose candidates are partitioned at a time (:func:`select`).
_BLOCK = 1024


def _continues_table(frames: MouthFrames, span: int) -> np.ndarray:
    """``(N,)``: how many of the next ``span`` frames continue the same clip."""
    follows = frames.continues()
    out = np.zeros(len(follows), np.int64)
    run = np.ones(len(follows), bool)
    for s in range(span):
        shifted = np.zeros(len(follows), bool)
        shifted[: len(follows) - s] = follows[s:]
        run &= shifted
        out += run
    return out


def _join(
    frames: MouthFrames, prev: np.ndarray, cur: np.ndarray, norm: float, colour: float
) -> np.ndarray:
    """The visual distance ``(len(prev), len(cur))`` of every pair of candidates."""
    a, b = frames.coords[prev], frames.coords[cur]
    shape = ((a[:, None, :] - b[None, :, :]) ** 2).sum(axis=2) / norm
    ca, cb = frames.border[prev], frames.border[cur]
    light = ((ca[:, None, :] - cb[None, :, :]) ** 2).mean(axis=2)
    return shape + colour * light


def drawn(frames: MouthFrames, path: np.ndarray, settings: SelectionSettings) -> list:
    """Each output frame as ``((frame, weight), ...)``: the chosen one, and at a jump the
    continuation it is blended with (:attr:`SelectionSettings.joins`) and their weights."""
    follows = frames.continues()
    n = len(path)
    rows: list[list[tuple[int, float]]] = [[(int(s), 1.0)] for s in path]
    for t in range(1, n):
        a, b = int(path[t - 1]), int(path[t])
        step = b - a
        joined = frames.clip[a] == frames.clip[b] and 0 <= step <= settings.continuation
        if joined:
            continue
        after_a = a + 1 if follows[a] else a
        before_b = b - 1 if b > 0 and follows[b - 1] else b
        f = settings.fade
        rows[t - 1] = _mix(rows[t - 1], before_b, f)
        rows[t] = _mix(rows[t], after_a, f)
    return [tuple(r) for r in rows]


def _mix(row: list[tuple[int, float]], other: int, amount: float) -> list[tuple[int, float]]:
    out = [(s, w * (1.0 - amount)) for s, w in row]
    return [*out, (other, amount)]


#: How the frames about a jump can be blended (:attr:`SelectionSettings.joins`).
JOINS = ("morph", "dissolve")
#: Pairs of training frames whose flows a :class:`PatchCompositor` keeps (the last used): a
#: pair comes back in other words, far apart (24 s of s1's recording: 101 of 160 joins'
#: first pairs seen before, 8 of them among the last 8 pairs, 68 among the last 32). Each
#: holds two flows of the mouth patch (under 1 MB for a 256-pixel crop's).
_KEPT_FLOWS = 128


class PatchCompositor:
    """Draws rows of weighted training frames onto a face (see the module docstring).

    ``joins`` blends the frames of a row (:data:`JOINS`); ``morph_options`` are the
    face's settings of :class:`~miketalk.render.morph.Morpher` for ``"morph"``; ``light``
    how each clip's patches are brought to the face's light
    (:data:`~miketalk.draw.trained.light.PATCH_LIGHTS`; None:
    :data:`miketalk.defaults.PATCH_LIGHT`).
    """

    def __init__(
        self,
        frames: MouthFrames,
        face: np.ndarray,
        *,
        joins: str = SelectionSettings.joins,
        morph_options: dict | None = None,
        light: str | None = None,
    ) -> None:
        if joins not in JOINS:
            raise MiketalkError(f"joins must be one of {', '.join(JOINS)}, not {joins!r}")
        x, y, w, h = frames.patch
        self.joins, self.morph_options = joins, dict(morph_options or {})
        self.frames = frames
        self.face = np.ascontiguousarray(face)
        self.mask = feather_mask(h, w)[..., None]
        self.under = self.face[y : y + h, x : x + w].astype(np.float32)
        self.light = patch_light(frames, self.face, light or defaults.PATCH_LIGHT)
        # the flows between two training frames, both ways: a join morphs the same two
        # frames over several output frames, at other weights (12 minutes of s1's recording
        # drew 1280 morphs; DIS was 30 % of the main process's CPU)
        self._flows: OrderedDict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = OrderedDict()
        # the last frame drawn: a row often repeats in the next frame (300 of 600)
        self._last: tuple[tuple, np.ndarray] | None = None

    def lit(self, s: int) -> np.ndarray:
        """Training frame ``s``'s patch brought to the face's light (float32)."""
        return self.light.apply(self.frames.patches[s], int(self.frames.clip[s]))

    def patch(self, row) -> np.ndarray:
        """The blended, light-matched patch of one output frame (float32)."""
        if len(row) == 1:
            return self.lit(row[0][0])
        if self.joins == "morph":
            return self._morphed(row)
        total = np.zeros(self.under.shape, np.float32)
        for s, w in row:
            total += np.float32(w) * self.lit(s)
        return total

    def _morphed(self, row) -> np.ndarray:
        """The row's frames morphed into one, each in turn at its share of the weight so far."""
        from miketalk.flow.opencv import dis_flow
        from miketalk.render.morph import Morpher

        image = np.clip(np.rint(self.lit(row[0][0])), 0, 255).astype(np.uint8)
        held = row[0][1]
        for k, (s, w) in enumerate(row[1:]):
            other = np.clip(np.rint(self.lit(s)), 0, 255).astype(np.uint8)
            key = (int(row[0][0]), int(s))  # the first step morphs two training frames
            flows = self._flows.get(key) if k == 0 else None
            if flows is not None:
                self._flows.move_to_end(key)
            else:
                flows = dis_flow(image, other), dis_flow(other, image)
                if k == 0:
                    self._flows[key] = flows
                    while len(self._flows) > _KEPT_FLOWS:
                        self._flows.popitem(last=False)
            morpher = Morpher(image, other, *flows, **self.morph_options)
            image = morpher.frame(float(w / (held + w)))
            held += w
        return image.astype(np.float32)

    def frame(self, row) -> np.ndarray:
        """The face with the output frame's mouth, (H, W, 3) uint8."""
        key = tuple((int(s), float(weight)) for s, weight in row)
        if self._last is not None and self._last[0] == key:
            return self._last[1].copy()
        out = self._frame(row)
        self._last = (key, out.copy())
        return out

    def _frame(self, row) -> np.ndarray:
        x, y, w, h = self.frames.patch
        blended = self.mask * self.patch(row) + (1.0 - self.mask) * self.under
        out = self.face.copy()
        out[y : y + h, x : x + w] = np.clip(np.rint(blended), 0, 255).astype(np.uint8)
        return out
