"""Typed text spoken sentence by sentence: the next sentence spoken while the face draws
this one, and the sentences joined into one utterance and one timeline.

Each sentence is its own utterance with its own timeline (its frames at ``k / fps`` from
its start, its sound fitted to its whole frames); sentence ``j`` starts at frame ``F_j``,
the frames of the sentences before it, so the joined video and sound stay in step to the
sample (:func:`miketalk.talk.frames.sample_bounds`). :func:`ahead` runs the speech one
sentence ahead of the drawing in a thread of its own; :class:`Joined` keeps what the JSON
and the measures of the motion need of the whole.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field, replace
from typing import TypeVar

from miketalk.lipsync.timeline import FrameSample, Keyframe, Timeline, Transition
from miketalk.speech.types import Phone, Utterance
from miketalk.talk.frames import sample_bounds
from miketalk.talk.stream import kill_thread_children

__all__ = ["Joined", "ahead", "in_context"]

T = TypeVar("T")
_POLL = 0.05
_JOIN = 5.0  # seconds a closed ahead() waits for its thread to unwind (its Festival killed)
_DONE = object()


def ahead(
    items: Iterable[T], *, depth: int = 1, check: Callable[[], None] | None = None
) -> Iterator[T]:
    """``items`` made by a thread of their own, at most ``depth`` ahead of the caller.

    What making an item raises is raised here, in order. When the caller stops early
    (an error, a stop, ``close()``), the thread makes no more items: the processes it
    started (the next sentence's Festival) are killed, and ``close()`` returns once the
    thread has ended, its scratch files removed (a run stopped by a signal ends the
    process at once after it: a thread still inside Festival's scratch directory then
    left it behind). Close the iterator explicitly (``contextlib.closing``): an exception
    passing through the caller's frame keeps the generator alive until it is dropped.
    ``check`` (a stream's :meth:`~miketalk.talk.stream.Emitter.check`) is called while the
    caller waits for the next item: a stop raises there, so a caller waiting on a sentence
    Festival is still making is not held until it ends.
    """
    handed: queue.Queue = queue.Queue(depth)
    stopped = threading.Event()

    def put(item: object) -> bool:
        while not stopped.is_set():
            try:
                handed.put(item, timeout=_POLL)
                return True
            except queue.Full:
                continue
        return False

    def make() -> None:
        try:
            for item in items:
                if not put((item, None)):
                    return
        except BaseException as err:  # handed to the caller
            put((None, err))
            return
        put((_DONE, None))

    thread = threading.Thread(target=make, name="miketalk-ahead", daemon=True)
    thread.start()
    try:
        while True:
            while True:
                try:
                    item, error = handed.get(timeout=_POLL)
                    break
                except queue.Empty:
                    if check is not None:
                        check()
            if error is not None:
                raise error
            if item is _DONE:
                return
            yield item
    finally:
        stopped.set()
        if thread.is_alive():
            kill_thread_children(thread)
            thread.join(_JOIN)


def in_context(timeline: Timeline, before: tuple | None, after: tuple | None) -> Timeline:
    """``timeline`` with the keyframes of the sentences either side (``(utterance, timeline,
    planned)`` or None) where they fall, before its start and after its end: what the learned
    coarticulation weighs the mouth with (its dominance reaches past a keyframe), so the
    mouth moves across a sentence's edge as it would in one utterance (without them, a
    sentence that opens on a ``p`` starts drawn with its lips already closing, a jump from
    the rest the one before ended on)."""
    keys = list(timeline.keyframes)
    if before is not None:
        shift = -len(before[1].frames) / timeline.fps
        keys = [replace(k, time=k.time + shift) for k in before[1].keyframes] + keys
    if after is not None:
        shift = len(timeline.frames) / timeline.fps
        keys += [replace(k, time=k.time + shift) for k in after[1].keyframes]
    return replace(timeline, keyframes=tuple(keys)) if before or after else timeline


@dataclass
class Joined:
    """Sentences drawn one after the other, joined: one timeline, one utterance.

    Parameters
    ----------
    fps : float
        The frame rate.
    """

    fps: float
    frames: int = 0
    duration: float = 0.0
    planned_duration: float = 0.0
    rate: int = 0
    phones: list[Phone] = field(default_factory=list)
    planned: list[Phone] = field(default_factory=list)
    keyframes: list[Keyframe] = field(default_factory=list)
    transitions: list[Transition] = field(default_factory=list)
    samples: list[FrameSample] = field(default_factory=list)
    sound: bytearray = field(default_factory=bytearray)  # int16 samples, grown in place
    chunks: list[tuple[str, int]] = field(default_factory=list)
    first: tuple[Utterance, Timeline] | None = None

    def add(
        self,
        utterance: Utterance,
        timeline: Timeline,
        planned: tuple[Phone, ...],
    ) -> None:
        """Append a sentence: its utterance, its timeline drawn from frame :attr:`frames`,
        its phones at the engine's own timing."""
        import numpy as np

        if self.first is None and not self.frames:
            self.first = (utterance, timeline)
        start = self.frames / self.fps  # exactly where its first frame shows
        n = len(timeline.frames)
        first, last = (
            sample_bounds(self.frames, utterance.rate, self.fps),
            sample_bounds(self.frames + n, utterance.rate, self.fps),
        )
        end = last / utterance.rate  # its sound, fitted to its frames, ends here
        phones = [replace(p, start=p.start + start, end=p.end + start) for p in timeline.phones]
        phones[0] = replace(phones[0], start=self.duration)
        phones[-1] = replace(phones[-1], end=end)
        self.phones += phones
        p0, t0 = len(self.phones) - len(phones), len(self.transitions)
        self.keyframes += [replace(k, time=k.time + start, phone=k.phone + p0)
                           for k in timeline.keyframes]  # fmt: skip
        self.transitions += [replace(t, start=t.start + start) for t in timeline.transitions]
        self.samples += [
            replace(
                f, index=f.index + self.frames, time=(f.index + self.frames) / self.fps,
                transition=f.transition + t0,
                samples=tuple((i + t0, a, w) for i, a, w in f.samples),
            )
            for f in timeline.frames
        ]  # fmt: skip
        own = round(planned[-1].end * utterance.rate) / utterance.rate
        self.planned += [replace(p, start=p.start + self.planned_duration,
                                 end=p.end + self.planned_duration) for p in planned]  # fmt: skip
        self.planned_duration += own
        sound = utterance.samples[: last - first]
        # appended in place (no list of pieces joined at the end: an hour's sound, 115 MB,
        # would be held twice)
        self.sound += (
            np.pad(sound, (0, last - first - len(sound))).astype(np.int16, copy=False).tobytes()
        )
        self.chunks.append((utterance.text, len(utterance.phones)))
        self.rate, self.duration, self.frames = utterance.rate, end, self.frames + n

    @property
    def one(self) -> bool:
        """Whether one sentence was said (its own timeline and utterance are the whole's)."""
        return len(self.chunks) == 1

    def timeline(self) -> Timeline:
        """The joined timeline (one sentence's own)."""
        if self.one and self.first is not None:
            return self.first[1]
        return Timeline(
            fps=self.fps, duration=self.duration, phones=tuple(self.phones),
            keyframes=tuple(self.keyframes), transitions=tuple(self.transitions),
            frames=tuple(self.samples),
        )  # fmt: skip

    def utterance(self, text: str) -> Utterance:
        """The joined utterance (its sound as the video plays it: fitted to whole frames); one
        sentence's own."""
        import numpy as np

        if self.one and self.first is not None:
            return replace(self.first[0], text=text)
        return Utterance(
            text=text, samples=np.frombuffer(self.sound, np.int16), rate=self.rate,
            phones=tuple(self.phones), chunks=tuple(self.chunks),
        )  # fmt: skip
