"""A talking-face model on disk: viseme images, their flow database, a manifest.

Layout of a model directory::

    manifest.json        format, visemes, image size, estimator + settings,
                         and each transition's largest flow displacement
    visemes/<slug>.png   one image per viseme (RGB)
    flows/               the flow database (:class:`miketalk.flow.FlowDatabase`)

The manifest is validated when the model is opened (every image present and of
the declared size, every flow file present); flows are read lazily, each file
checked as it is read, and morphers for recently used transitions are cached.
"""

from __future__ import annotations

import json
import os
import shutil
from collections import OrderedDict
from collections.abc import Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from itertools import combinations
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from miketalk.errors import MiketalkError
from miketalk.flow import FlowDatabase
from miketalk.media.atomic import write_text_atomic
from miketalk.media.images import read_image
from miketalk.morph import Morpher
from miketalk.talk.lipsync import Timeline
from miketalk.visemes import viseme_slug

if TYPE_CHECKING:  # pandas is not imported by `miketalk say`
    import pandas as pd

FORMAT = "miketalk-model/1"


class Model:
    """A model opened from ``directory`` (see the module docstring).

    Parameters
    ----------
    directory : path
        The model directory.
    cache_size : int
        How many transitions' morphers to keep ready.
    morph_options : dict, optional
        Keyword flags for :class:`miketalk.morph.Morpher` (``hole_aware_blend``,
        ``fill_holes``, ``median``).

    Raises
    ------
    MiketalkError
        If the directory, its manifest, an image or a flow file is missing or
        does not match the manifest.
    """

    def __init__(
        self,
        directory: str | os.PathLike[str],
        *,
        cache_size: int = 24,
        morph_options: dict | None = None,
    ) -> None:
        self.directory = Path(directory)
        self.morph_options = dict(morph_options or {})
        path = self.directory / "manifest.json"
        if not path.exists():
            raise MiketalkError(f"no model at {self.directory} (missing manifest.json)")
        try:
            manifest = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError) as err:
            raise MiketalkError(f"cannot read model manifest {path}: {err}") from err
        if manifest.get("format") != FORMAT:
            raise MiketalkError(f"{path} is not a {FORMAT} manifest")
        self.manifest = manifest
        self.visemes: tuple[str, ...] = tuple(manifest["visemes"])
        self.size: tuple[int, int] = tuple(manifest["size"])  # (H, W)
        self._images: dict[str, np.ndarray] = {}
        for viseme in self.visemes:
            image = read_image(self.directory / manifest["images"][viseme])
            if image.shape[:2] != self.size:
                raise MiketalkError(
                    f"viseme image {manifest['images'][viseme]} is {image.shape[1]}x"
                    f"{image.shape[0]}, the manifest says {self.size[1]}x{self.size[0]}"
                )
            self._images[viseme] = image
        self.flows = FlowDatabase(self.directory / "flows")
        check_complete(self.flows, self.visemes)
        self._displacement = {
            tuple(k.split("|")): float(v) for k, v in manifest["max_displacement"].items()
        }
        self._morphers: OrderedDict[tuple[str, str], Morpher] = OrderedDict()
        self._cache_size = cache_size
        # every flow file is read by this one thread (FlowDatabase is not
        # thread-safe), ahead of the render when prefetch() is told what comes
        self._reader = ThreadPoolExecutor(1, thread_name_prefix="miketalk-flows")
        self._reads: dict[tuple[str, str], Future] = {}

    def image(self, viseme: str) -> np.ndarray:
        """The viseme's image, (H, W, 3) uint8."""
        self._check(viseme)
        return self._images[viseme]

    def displacement(self, a: str, b: str) -> float:
        """The largest flow displacement of transition a -> b, in pixels (0 for a == b)."""
        self._check(a)
        self._check(b)
        return 0.0 if a == b else self._displacement[(a, b)]

    def morpher(self, a: str, b: str) -> Morpher:
        """A morpher for transition a -> b (cached)."""
        key = (a, b)
        if key in self._morphers:
            self._morphers.move_to_end(key)
            return self._morphers[key]
        forward, backward = self._read(a, b).result()
        self._reads.pop(key, None)
        morpher = Morpher(self.image(a), self.image(b), forward, backward, **self.morph_options)
        self._morphers[key] = morpher
        if len(self._morphers) > self._cache_size:
            self._morphers.popitem(last=False)
        return morpher

    def prefetch(self, transitions: Iterable[tuple[str, str]]) -> None:
        """Start reading the flows of ``transitions`` (in order) in the background.

        :meth:`morpher` then finds them read (or being read) instead of reading
        them itself; rendering a timeline overlaps with reading its flows.
        """
        for a, b in transitions:
            if a != b and (a, b) not in self._morphers:
                self._read(a, b)

    def _read(self, a: str, b: str) -> Future:
        key = (a, b)
        if key not in self._reads:
            self._check(a)
            self._check(b)
            self._reads[key] = self._reader.submit(
                lambda: (self.flows.flow(a, b), self.flows.flow(b, a))
            )
        return self._reads[key]

    def frame(self, a: str, b: str, alpha: float) -> np.ndarray:
        """The morph from viseme a to b at ``alpha``."""
        if a == b or alpha <= 0.0:
            return self.image(a)
        if alpha >= 1.0:
            return self.image(b)
        return self.morpher(a, b).frame(alpha)

    def render(self, timeline: Timeline, *, lookahead: int = 8) -> Iterator[np.ndarray]:
        """The frames of a timeline, in order.

        The flows of the next ``lookahead`` transitions are read in a thread
        while the current one is drawn.
        """
        pairs = [(t.source, t.target) for t in timeline.transitions]
        ahead = 0
        for sample in timeline.frames:
            if sample.transition >= ahead - lookahead // 2:
                ahead = min(len(pairs), sample.transition + lookahead)
                self.prefetch(pairs[sample.transition : ahead])
            t = timeline.transitions[sample.transition]
            yield self.frame(t.source, t.target, sample.alpha)

    def _check(self, viseme: str) -> None:
        if viseme not in self._images:
            raise MiketalkError(
                f"the model has no viseme {viseme!r} (it has {' '.join(self.visemes)})"
            )


def check_complete(flows: FlowDatabase, visemes: tuple[str, ...] | list[str]) -> None:
    """Raise MiketalkError naming the first missing pair file of ``visemes``."""
    for a, b in combinations(visemes, 2):
        path = flows.path_for(a, b)
        if not path.exists():
            raise MiketalkError(f"flow file {path} for visemes {a!r} and {b!r} is missing")


def largest_displacement(flow: np.ndarray, *, quantile: float = 0.999) -> float:
    """The paper's "maximal offset vector" of a flow, robust to stray vectors.

    The 99.9th percentile of the vector lengths rather than the very longest:
    an estimated flow has a few wild vectors (textureless background, occlusion
    borders) that are no motion at all, and would make oversampling slow every
    transition down. On true flows the two agree to a fraction of a pixel.
    """
    length = np.sqrt((flow.astype(np.float64) ** 2).sum(axis=-1))
    return float(np.quantile(length, quantile))


def build_model(
    out_dir: str | os.PathLike[str],
    *,
    images: dict[str, str | os.PathLike[str]],
    flows_dir: str | os.PathLike[str],
    estimator: str,
    settings: dict,
    fallbacks: dict[str, str] | None = None,
) -> Path:
    """Assemble a model directory from viseme images and a flow database.

    Images and flow files are hard-linked where possible (copied otherwise);
    the manifest is written last, so a model without one is incomplete.
    ``fallbacks`` (viseme -> the class whose image it borrows, for a class the
    recording had no instance of) is listed in the manifest.
    """
    out = Path(out_dir)
    (out / "visemes").mkdir(parents=True, exist_ok=True)
    names = list(images)
    sizes = set()
    image_paths = {}
    for viseme, src in images.items():
        rel = f"visemes/{viseme_slug(viseme)}.png"
        sizes.add(read_image(src).shape[:2])
        _link(Path(src), out / rel)
        image_paths[viseme] = rel
    if len(sizes) != 1:
        raise MiketalkError(f"viseme images differ in size: {sorted(sizes)}")
    source = FlowDatabase(flows_dir)
    check_complete(source, names)
    if (out / "flows").exists():
        shutil.rmtree(out / "flows")
    (out / "flows").mkdir()
    for a, b in combinations(names, 2):
        path = source.path_for(a, b)
        _link(path, out / "flows" / path.name)
    displacement = {
        f"{a}|{b}": largest_displacement(source.flow(a, b)) for a in names for b in names if a != b
    }
    manifest = {
        "format": FORMAT,
        "visemes": names,
        "size": list(sizes.pop()),
        "estimator": estimator,
        "settings": settings,
        "images": image_paths,
        "max_displacement": displacement,
    }
    if fallbacks:
        manifest["fallbacks"] = dict(sorted(fallbacks.items()))
    write_text_atomic(out / "manifest.json", json.dumps(manifest, indent=1, sort_keys=True))
    return out


def fallbacks_of(visemes: pd.DataFrame) -> dict[str, str]:
    """``viseme -> donor`` from a ``visemes.tsv`` table's ``fallback`` column (empty: none)."""
    if "fallback" not in visemes.columns:
        return {}
    return {
        str(v): str(f)
        for v, f in zip(visemes["viseme"], visemes["fallback"], strict=True)
        if isinstance(f, str) and f
    }


def _link(src: Path, dst: Path) -> None:
    dst.unlink(missing_ok=True)
    try:
        os.link(src, dst)
    except OSError:
        shutil.copyfile(src, dst)
