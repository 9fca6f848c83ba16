"""The morph's C kernels (``_morph_kernels.c``): the splat, the blend and the scanline hole fill.

Built by ``pip install`` (``setup.py``); a source tree used without installing it
gets one clear message instead of a bare import error.
"""

try:
    from miketalk.render._morph_kernels import fill_holes, render, splat
except ImportError as err:  # a source tree used without installing it
    raise ImportError(
        "miketalk's C extension (src/miketalk/render/_morph_kernels.c) is not built: "
        "run `make setup`, or `pip install -e .` in the source tree"
    ) from err

__all__ = ["fill_holes", "render", "splat"]
