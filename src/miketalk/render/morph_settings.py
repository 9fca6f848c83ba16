"""The morph's refinements (paper §5.4) as one checked setting: what :class:`Morpher`
(:mod:`miketalk.render.morph`) takes and the workflow's ``morph`` configures."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields

from miketalk.errors import MiketalkError
from miketalk.render.splat import Collision, Splat, _check_collision, _check_splat

__all__ = ["MorphSettings"]


@dataclass(frozen=True)
class MorphSettings:
    """The morph's refinements (paper §5.4), each of which can be turned off: the keyword
    settings of :class:`Morpher` and the workflow's ``morph`` (``tests/test_vocabulary.py``
    checks that the three agree).

    Attributes
    ----------
    hole_aware_blend : bool
        Take the non-hole side where one warp leaves a hole.
    fill_holes : bool
        Fill remaining holes along scanlines.
    median : bool
        3x3 median filter after filling.
    collision : {"motion", "scan"}
        Collision rule of the forward warps (see the module docstring).
    splat : {"nearest", "bilinear"}
        How the forward warp puts a pixel down.
    """

    hole_aware_blend: bool = True
    fill_holes: bool = True
    median: bool = True
    collision: Collision = "motion"
    splat: Splat = "nearest"

    def __post_init__(self) -> None:
        _check_collision(self.collision)
        _check_splat(self.splat)

    @classmethod
    def of(cls, options: Mapping[str, object] | MorphSettings | None) -> MorphSettings:
        """Settings from a mapping of some of them (None: the defaults).

        Raises
        ------
        MiketalkError
            In one line, for a setting that is not one, or a bad value.
        """
        if isinstance(options, MorphSettings):
            return options
        options = dict(options or {})
        known = [f.name for f in fields(cls)]
        if unknown := sorted(set(options) - set(known)):
            raise MiketalkError(
                f"unknown morph setting {', '.join(unknown)} (known: {', '.join(known)})"
            )
        return cls(**options)  # type: ignore[arg-type]

    def to_dict(self) -> dict[str, object]:
        """The settings by name (:class:`Morpher`'s keywords)."""
        return asdict(self)
