"""The parametric face: mesh, linear blendshapes and the corpus targets, with no rendering."""

from __future__ import annotations

from collections.abc import Mapping
from functools import cache

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.visemes import VisemeTable, default_table
from synth_face.blendshapes import PARAMS, part_deltas
from synth_face.mouth import build_cavity, build_lower_teeth, build_tongue, build_upper_teeth
from synth_face.part import Part
from synth_face.skin import build_skin
from synth_face.targets import TARGETS


@cache
def _build() -> tuple[tuple[Part, ...], np.ndarray, np.ndarray]:
    parts = (build_skin(), build_upper_teeth(), build_lower_teeth(), build_tongue(), build_cavity())
    rest = np.concatenate([p.rest for p in parts])
    deltas = np.concatenate([part_deltas(p) for p in parts], axis=1)
    rest.setflags(write=False)
    deltas.setflags(write=False)
    return parts, rest, deltas


class Face:
    """A synthetic face whose mouth moves by a linear blendshape model.

    ``vertices(p) = rest + sum_i p[i] * deltas[i]``, over the mouth parameters
    :attr:`param_names` (each in ``[0, 1]``). Teeth and tongue are part of the same model:
    the upper teeth are fixed, the lower teeth and the tongue turn with the jaw, the tongue
    also has its own two parameters. Everything is deterministic.

    Parameters
    ----------
    table : VisemeTable, optional
        The phone and corpus tables :meth:`phone_targets` uses; the packaged ones by default.

    Attributes
    ----------
    parts : tuple of Part
        ``skin`` (with the lips), ``upper_teeth``, ``lower_teeth``, ``tongue``, ``cavity``,
        in this order; their vertices are consecutive in :attr:`rest`.
    rest : ndarray, shape (N, 3)
        Rest vertex positions (mm; x right, y up, z towards the camera).
    deltas : ndarray, shape (P, N, 3)
        Displacement of every vertex per unit of every parameter (mm).
    triangles : ndarray, shape (T, 3)
        All triangles, indexing :attr:`rest`.
    """

    def __init__(self, table: VisemeTable | None = None) -> None:
        self.table = default_table() if table is None else table
        self.parts, self.rest, self.deltas = _build()
        self._rest_flat = self.rest.reshape(-1)
        self._deltas_flat = self.deltas.reshape(self.deltas.shape[0], -1)
        self.param_names: tuple[str, ...] = tuple(p.name for p in PARAMS)
        self.param_low = np.array([p.low for p in PARAMS])
        self.param_high = np.array([p.high for p in PARAMS])
        offsets = np.cumsum([0] + [p.rest.shape[0] for p in self.parts])
        self.vertex_slices: dict[str, slice] = {
            p.name: slice(int(a), int(b))
            for p, a, b in zip(self.parts, offsets, offsets[1:], strict=False)
        }
        self.triangles = np.concatenate(
            [p.triangles + off for p, off in zip(self.parts, offsets[:-1], strict=True)]
        )
        missing = [t.key for t in self.table.targets if t.key not in TARGETS]
        if missing:
            raise MiketalkError(f"the synthetic face has no pose for corpus targets {missing}")

    @property
    def n_params(self) -> int:
        """Number of mouth parameters P."""
        return len(self.param_names)

    @property
    def target_keys(self) -> tuple[str, ...]:
        """Every corpus target key the face has a pose for."""
        return tuple(TARGETS)

    def check_params(self, params: np.ndarray | list[float] | tuple[float, ...]) -> np.ndarray:
        """Validate a parameter vector and return it as float64, shape ``(P,)``.

        Raises
        ------
        MiketalkError
            On a wrong shape, non-finite values or values outside a parameter's range.
        """
        p = np.asarray(params, dtype=np.float64)
        if p.shape != (self.n_params,):
            raise MiketalkError(
                f"face parameters must have shape ({self.n_params},) for "
                f"{', '.join(self.param_names)}; got shape {p.shape}"
            )
        if not np.all(np.isfinite(p)):
            raise MiketalkError(f"face parameters must be finite, got {p}")
        bad = (p < self.param_low - 1e-9) | (p > self.param_high + 1e-9)
        if bad.any():
            names = [
                f"{n}={v:g} (range [{lo:g}, {hi:g}])"
                for n, v, lo, hi, b in zip(
                    self.param_names, p, self.param_low, self.param_high, bad, strict=True
                )
                if b
            ]
            raise MiketalkError(f"face parameters out of range: {', '.join(names)}")
        return p

    def params(self, values: Mapping[str, float] | None = None, **named: float) -> np.ndarray:
        """A parameter vector from names, the others zero: ``face.params(jaw_open=0.5)``.

        Raises
        ------
        MiketalkError
            For an unknown name or a value out of range.
        """
        named = {**(values or {}), **named}
        p = np.zeros(self.n_params)
        for name, value in named.items():
            if name not in self.param_names:
                raise MiketalkError(
                    f"unknown face parameter {name!r}; known: {', '.join(self.param_names)}"
                )
            p[self.param_names.index(name)] = value
        return self.check_params(p)

    def vertices(self, params: np.ndarray) -> np.ndarray:
        """Vertex positions at ``params``: ``rest + sum_i params[i] * deltas[i]`` (mm)."""
        p = self.check_params(params)
        # einsum, not BLAS: OpenBLAS's threaded gemv is ten times slower on a busy machine.
        flat = self._rest_flat + np.einsum("i,ij->j", p, self._deltas_flat)
        return flat.reshape(-1, 3)

    def target(self, key: str) -> np.ndarray:
        """The parameters of a corpus target (``"b"``, ``"ii"``, ``"ou:1"``, ``"#"``).

        Raises
        ------
        MiketalkError
            For a key that is not a corpus target.
        """
        try:
            row = TARGETS[key]
        except KeyError:
            raise MiketalkError(
                f"unknown corpus target {key!r}; known: {' '.join(TARGETS)}"
            ) from None
        return np.array(row, dtype=np.float64)

    def phone_targets(self, radio_phone: str) -> tuple[np.ndarray, ...]:
        """The target(s) of a Festival radio phone: one, or two nuclei for a diphthong.

        Raises
        ------
        MiketalkError
            For a phone the phone table does not know.
        """
        return tuple(self.target(t.key) for t in self.table.targets_of(radio_phone))
