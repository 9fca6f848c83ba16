"""What each use case returns: typed results, read by the front ends to say what was made."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from miketalk.lipsync.settings import Sampling

if TYPE_CHECKING:
    from miketalk.lipsync.motion import Motion
    from miketalk.speech.types import Phone
    from miketalk.talk.utterance import Spoken

__all__ = ["BuildResult", "CuesResult", "DubResult", "SayResult"]


@dataclass(frozen=True)
class SayResult:
    """What ``say`` made.

    Attributes
    ----------
    spoken : Spoken
        The timeline of the frames, the measures of their motion, the two files written.
    fps : float
        The frame rate it was drawn at (the one asked for, else the one chosen).
    sampling : Sampling
        How fast transitions were drawn.
    max_px_per_frame : float or None
        The step limit kept (None: none).
    max_slowdown : float or None
        The cap on the paper's lengthening.
    voice : str or None
        Festival's voice (None: a recording spoke).
    audio : str or None
        The recording that spoke (None: Festival's voice).
    """

    spoken: Spoken
    fps: float
    sampling: Sampling
    max_px_per_frame: float | None
    max_slowdown: float | None = None
    voice: str | None = None
    audio: str | None = None

    @property
    def video(self) -> Path:
        """The mp4."""
        return self.spoken.video

    @property
    def timeline_json(self) -> Path:
        """Its timeline JSON, beside it."""
        return self.spoken.timeline_json

    @property
    def motion(self) -> Motion:
        """The measures of the mouth's motion."""
        return self.spoken.motion

    @property
    def lipsync_model(self) -> str:
        """The lip-sync model that drew the mouth."""
        return self.spoken.lipsync_model

    @property
    def trajectory(self) -> str | None:
        """The trained face's trajectory model (None: another lip-sync model)."""
        return self.spoken.trajectory

    @property
    def recorded(self) -> bool:
        """Whether a recording spoke."""
        return self.audio is not None

    def cues(self) -> list:
        """The mouth cues of what was said (Rhubarb's shapes, :mod:`miketalk.lipsync.cues`)."""
        from miketalk.lipsync.cues import mouth_cues
        from miketalk.visemes import default_table

        phones = self.spoken.timeline.phones
        return mouth_cues(phones, default_table(), duration=self.spoken.duration)

    def cues_text(self, fmt: str, *, sound_file: str = "") -> str:
        """The mouth cues as the text of a file of format ``fmt`` (``json``, ``tsv``,
        ``textgrid``) that names the sound ``sound_file``."""
        from miketalk.lipsync.cues import render_cues
        from miketalk.visemes import default_table

        return render_cues(
            fmt, self.spoken.timeline.phones, default_table(), duration=self.spoken.duration,
            sound_file=sound_file,
        )  # fmt: skip

    @property
    def seconds(self) -> float:
        """Seconds of speech the mp4 plays (a recording's: whole frames, so at most half a
        frame more or less than the recording)."""
        if self.recorded:
            return min(self.spoken.duration, self.motion.frames / self.fps)
        return self.spoken.duration


@dataclass(frozen=True)
class DubResult(SayResult):
    """What ``dub`` made: :class:`SayResult`, and of the video dubbed the following.

    Attributes
    ----------
    source : Path
        The video.
    size : tuple of int
        Its frames' height and width.
    source_frames : int
        How many frames it has.
    blinks : tuple of int
        The frames where the person blinks.
    """

    source: Path = Path()
    size: tuple[int, int] = (0, 0)
    source_frames: int = 0
    blinks: tuple[int, ...] = ()

    @property
    def looped(self) -> bool:
        """Whether the speech outlasts the video (played forwards, backwards, forwards)."""
        return self.motion.frames > self.source_frames


@dataclass(frozen=True)
class BuildResult:
    """What ``build`` made.

    Attributes
    ----------
    model : Path
        The model's directory.
    utterances, held_out : int
        The utterances it was built from, and those held out.
    words, unaligned_words : int
        The transcript's words, and those not aligned.
    stage_seconds : dict of str to float
        Each stage's time.
    recording_lipsync : str
        The lip-sync model the model draws a recording with, unless told.
    trained_cv_r2 : float or None
        The trained face's leave-clip-out R² (None: no trained face).
    lipsync_scores : dict of str to float
        How well each lip-sync model followed his mouth on the held-back training clips
        the build chose ``recording_lipsync`` by (:mod:`miketalk.building.lipsync_choice`;
        empty: too little to judge on, or no trained face).
    lipsync_reason : str
        Why ``recording_lipsync``, in one line ('' for a model without the choice).
    """

    model: Path
    utterances: int
    held_out: int
    words: int
    unaligned_words: int
    stage_seconds: dict[str, float]
    recording_lipsync: str = "paper"
    trained_cv_r2: float | None = None
    lipsync_scores: dict[str, float] = field(default_factory=dict)
    lipsync_reason: str = ""


@dataclass(frozen=True)
class CuesResult:
    """What ``cues`` made: the timed phones, and the files written.

    Attributes
    ----------
    phones : tuple of Phone
        The phones, timed.
    duration : float
        Seconds of sound.
    sound_file : str
        The sound the cues are of, as a full path ('' when it was not kept).
    extended_shapes : str
        Rhubarb's extended shapes used.
    written : tuple of Path
        The files written.
    """

    phones: tuple[Phone, ...]
    duration: float
    sound_file: str
    extended_shapes: str
    written: tuple[Path, ...] = ()

    def render(self, fmt: str) -> str:
        """The cues as the text of a file of format ``fmt`` (``json``, ``tsv``, ``textgrid``)."""
        from miketalk.lipsync.cues import render_cues
        from miketalk.visemes import default_table

        return render_cues(
            fmt, self.phones, default_table(), duration=self.duration,
            sound_file=self.sound_file, extended=self.extended_shapes,
        )  # fmt: skip
