"""The viseme images and the flows between them, morphed: the paper's face, drawn.

:class:`Morphs` holds a model's viseme images and reads its flow database
(:class:`miketalk.flow.FlowDatabase`) lazily, in one thread, ahead of the render when told
what comes; morphers for recently used transitions are cached, one set per thread. A
timeline frame with several samples (motion blur, :func:`miketalk.lipsync.sampling.motion_blur`)
is rendered as the weighted average of its morphs. :class:`miketalk.model.face.Model` is a
:class:`Morphs` opened from a model directory, with the model's other parts.
"""

from __future__ import annotations

import threading
from collections import OrderedDict, deque
from collections.abc import Iterable, Iterator, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor

import cv2
import numpy as np

from miketalk.errors import MiketalkError
from miketalk.flow import FlowDatabase
from miketalk.lipsync.timeline import FrameSample, Timeline
from miketalk.render.morph import Morpher
from miketalk.workers import RENDER_WORKERS


class Morphs:
    """Viseme images and their flows, morphed into frames.

    Parameters
    ----------
    images : mapping
        ``viseme -> (H, W, 3) uint8`` image, all of ``size``.
    flows : FlowDatabase
        The flows between them.
    displacement : mapping
        ``(a, b) -> `` the largest flow displacement of transition ``a -> b``, pixels.
    size : (int, int)
        ``(H, W)``.
    cache_size : int
        How many transitions' morphers to keep ready (per thread).
    morph_options : dict, optional
        Some of :class:`miketalk.render.morph_settings.MorphSettings` by name.
    """

    def __init__(
        self,
        images: Mapping[str, np.ndarray],
        flows: FlowDatabase,
        displacement: Mapping[tuple[str, str], float],
        size: tuple[int, int],
        *,
        cache_size: int = 24,
        morph_options: dict | None = None,
    ) -> None:
        self._images = dict(images)
        self.visemes: tuple[str, ...] = tuple(self._images)
        self.flows = flows
        self._displacement = dict(displacement)
        self.size = size
        self.morph_options = dict(morph_options or {})
        # each thread has its own morphers (a Morpher reuses its work buffers)
        self._local = threading.local()
        self._cache_size = cache_size
        # every flow file is read by this one thread (FlowDatabase is not
        # thread-safe), ahead of the render when prefetch() is told what comes
        self._reader = ThreadPoolExecutor(1, thread_name_prefix="miketalk-flows")
        self._reads: dict[tuple[str, str], Future] = {}
        self._lock = threading.Lock()

    def close(self) -> None:
        """Wait for the flow reads under way and stop the reading thread (idempotent).

        No more flows are read after this; images, displacements and the morphers
        already made still work.
        """
        self._reader.shutdown(wait=True, cancel_futures=True)

    def image(self, viseme: str) -> np.ndarray:
        """The viseme's image, (H, W, 3) uint8."""
        self._check(viseme)
        return self._images[viseme]

    def lit_image(self, viseme: str) -> np.ndarray:
        """The viseme's image as the paper's morph draws it (``lit=True``): here the image
        itself; a :class:`~miketalk.model.face.Model` from clips brings it to its face's
        light."""
        return self.image(viseme)

    def displacement(self, a: str, b: str) -> float:
        """The largest flow displacement of transition a -> b, in pixels (0 for a == b)."""
        self._check(a)
        self._check(b)
        return 0.0 if a == b else self._displacement[(a, b)]

    @property
    def _morphers(self) -> OrderedDict[tuple[str, str, bool], Morpher]:
        """This thread's morphers ``(a, b, lit)``, least recently used first."""
        cache = getattr(self._local, "morphers", None)
        if cache is None:
            cache = self._local.morphers = OrderedDict()
        return cache

    def morpher(self, a: str, b: str, *, lit: bool = False) -> Morpher:
        """A morpher for transition a -> b (cached; each thread has its own), between the
        :meth:`lit_image` images with ``lit``."""
        key = (a, b, lit)
        morphers = self._morphers
        if key in morphers:
            morphers.move_to_end(key)
            return morphers[key]
        try:
            forward, backward = self._read(a, b).result()
            for flow in (forward, backward):
                if flow.shape[:2] != self.size:
                    raise MiketalkError(
                        f"flow file {self.flows.path_for(a, b)} holds flows of "
                        f"{flow.shape[1]}x{flow.shape[0]} pixels, but the model's images are "
                        f"{self.size[1]}x{self.size[0]}: it belongs to another model"
                    )
            image = self.lit_image if lit else self.image
            morpher = Morpher(image(a), image(b), forward, backward, **self.morph_options)
        except MiketalkError as err:
            path = self.flows.path_for(a, b)
            if path.name in str(err):
                raise
            raise MiketalkError(
                f"flow file {path} ({a} -> {b}) does not fit the model: {err}"
            ) from None
        finally:
            with self._lock:
                self._reads.pop((a, b), None)
        morphers[key] = morpher
        if len(morphers) > self._cache_size:
            morphers.popitem(last=False)
        return morpher

    def prefetch(self, transitions: Iterable[tuple[str, str]]) -> None:
        """Start reading the flows of ``transitions`` (in order) in the background.

        :meth:`morpher` then finds them read (or being read) instead of reading
        them itself; rendering a timeline overlaps with reading its flows.
        """
        for a, b in transitions:
            if a != b and not {(a, b, True), (a, b, False)} & self._morphers.keys():
                self._read(a, b)

    def _read(self, a: str, b: str) -> Future:
        key = (a, b)
        with self._lock:
            if key not in self._reads:
                self._check(a)
                self._check(b)
                self._reads[key] = self._reader.submit(self._read_pair, a, b)
            return self._reads[key]

    def _read_pair(self, a: str, b: str) -> tuple[np.ndarray, np.ndarray]:
        """Flows ``a -> b`` and ``b -> a`` (the reading thread): kept decoded in the user's
        cache when :meth:`flow_identity` names the pair's file
        (:func:`~miketalk.media.kept_frames.kept_arrays`), else read from it."""
        identity = self.flow_identity(a, b)
        if identity is not None:
            from miketalk.media.kept_frames import kept_arrays

            kept = kept_arrays(
                "flows", (identity, a, b), lambda: (self.flows.flow(a, b), self.flows.flow(b, a))
            )
            if kept is not None:
                for flow in kept:
                    flow.flags.writeable = False  # as the database's own
                return kept[0], kept[1]
        return self.flows.flow(a, b), self.flows.flow(b, a)

    def flow_identity(self, a: str, b: str) -> object | None:
        """What the file of the flows between ``a`` and ``b`` is (a
        :class:`~miketalk.model.face.Model`: its size and SHA-256, checked when the model
        was opened); None here: unknown, never kept."""
        return None

    def flow_pair(self, a: str, b: str) -> tuple[np.ndarray, np.ndarray]:
        """Flows ``a -> b`` and ``b -> a`` (float32) through the model's one reading thread.

        The :class:`~miketalk.flow.FlowDatabase` is read by one thread only (it is
        not thread-safe); the reading future is dropped once collected, as
        :meth:`morpher` does.
        """
        future = self._read(a, b)
        try:
            forward, backward = future.result()
        finally:
            with self._lock:
                if self._reads.get((a, b)) is future:
                    self._reads.pop((a, b))
        for flow in (forward, backward):
            if flow.shape[:2] != self.size:
                raise MiketalkError(f"flow {a} -> {b} is not of the model's size {self.size}")
        return (
            np.ascontiguousarray(forward, np.float32),
            np.ascontiguousarray(backward, np.float32),
        )

    def frame(self, a: str, b: str, alpha: float, *, lit: bool = False) -> np.ndarray:
        """The morph from viseme a to b at ``alpha`` (of the :meth:`lit_image` images with
        ``lit``: the paper's drawing, :meth:`draw`)."""
        image = self.lit_image if lit else self.image
        if a == b or alpha <= 0.0:
            return image(a)
        if alpha >= 1.0:
            return image(b)
        return self.morpher(a, b, lit=lit).frame(alpha)

    def exposure(
        self, timeline: Timeline, samples: Sequence[tuple[int, float, float]]
    ) -> np.ndarray:
        """A motion-blurred frame: the average of the morphs ``(transition, alpha, weight)``.

        The weights sum to 1; the sum is accumulated in float32 in the order
        given (so the same samples give the same bytes) and rounded.
        """
        total = np.zeros((*self.size, 3), np.float32)
        for i, alpha, weight in samples:
            t = timeline.transitions[i]
            image = self.frame(t.source, t.target, alpha, lit=True)
            cv2.addWeighted(image, weight, total, 1.0, 0.0, dst=total, dtype=cv2.CV_32F)
        return np.clip(np.rint(total), 0, 255).astype(np.uint8)

    def draw(self, timeline: Timeline, sample: FrameSample) -> np.ndarray:
        """One frame of ``timeline``: its one morph, or the :meth:`exposure` of its samples."""
        if sample.samples:
            return self.exposure(timeline, sample.samples)
        t = timeline.transitions[sample.transition]
        return self.frame(t.source, t.target, sample.alpha, lit=True)

    def render(
        self, timeline: Timeline, *, lookahead: int = 8, workers: int | None = None
    ) -> Iterator[np.ndarray]:
        """The frames of a timeline, in order (:meth:`draw`).

        The flows of the next ``lookahead`` transitions are read in a thread
        while the current one is drawn, and ``workers`` threads draw frames
        side by side (the morph kernel runs without the GIL). The frames do not
        depend on the number of workers.

        Parameters
        ----------
        timeline : Timeline
            What to draw.
        lookahead : int
            Transitions whose flows are read ahead.
        workers : int, optional
            Threads drawing frames (default :data:`RENDER_WORKERS`; 1 draws in
            the calling thread).
        """
        workers = RENDER_WORKERS if workers is None else max(1, int(workers))
        pairs = [(t.source, t.target) for t in timeline.transitions]
        ahead = 0

        def read_ahead(sample: FrameSample) -> None:
            nonlocal ahead
            last = sample.samples[-1][0] if sample.samples else sample.transition
            if last >= ahead - lookahead // 2:
                ahead = min(len(pairs), last + lookahead)
                self.prefetch(pairs[sample.transition : ahead])

        if workers == 1:
            for sample in timeline.frames:
                read_ahead(sample)
                yield self.draw(timeline, sample)
            return
        pending: deque[Future] = deque()
        with ThreadPoolExecutor(workers, thread_name_prefix="miketalk-render") as pool:
            try:
                for sample in timeline.frames:
                    read_ahead(sample)
                    pending.append(pool.submit(self.draw, timeline, sample))
                    if len(pending) > 8 * workers:
                        yield pending.popleft().result()
                while pending:
                    yield pending.popleft().result()
            finally:
                for future in pending:
                    future.cancel()

    def _check(self, viseme: str) -> None:
        if viseme not in self._images:
            raise MiketalkError(
                f"the model has no viseme {viseme!r} (it has {' '.join(self.visemes)})"
            )
