"""Build of the one C extension (the morph's kernels); everything else is in pyproject.toml.

``-ffp-contract=off`` keeps the compiler from fusing a multiply and an add into
one FMA instruction (GCC does by default where the CPU has FMA, e.g. on
aarch64): the kernels' rounding then gives the same bytes on every machine.
"""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "miketalk.render._morph_kernels",
            sources=["src/miketalk/render/_morph_kernels.c"],
            extra_compile_args=["-O3", "-ffp-contract=off"],
        )
    ]
)
