"""The encoder: the ffmpeg binary, and x264's settings (the file writer's, kept for quality;
the live stream's, for speed)."""

from __future__ import annotations

from dataclasses import dataclass

from miketalk.errors import MiketalkError

__all__ = ["FILE_X264", "LIVE_X264", "X264", "ffmpeg_exe"]


@dataclass(frozen=True)
class X264:
    """How x264 encodes a stream: its preset, constant rate factor and tune.

    Two are used: :data:`FILE_X264` for an mp4 written to keep, :data:`LIVE_X264` for a
    stream watched as it is made. Every setting keeps the output deterministic (one
    thread: the bitstream does not depend on the machine's cores).
    """

    preset: str = "veryfast"
    crf: int = 18
    tune: str | None = None

    def args(self) -> list[str]:
        """ffmpeg's output options of the video stream."""
        tune = ["-tune", self.tune] if self.tune else []
        return ["-c:v", "libx264", "-preset", self.preset, *tune, "-crf", str(self.crf)]


#: An mp4 file: crf 18 (visually lossless) at ``veryfast``. On the 304 frames of 10.14 s of
#: the weekly addresses at 720p (yuv420p in, ``python -m miketalk_lab.bench speed``): 7.9 ms
#: of CPU a frame, 1.55 MB, PSNR 48.1 dB against its input.
FILE_X264 = X264("veryfast", 18)

#: A stream watched as it is made (the page's live Speak): ``ultrafast``, crf 20, which has
#: no look-ahead and no B-frames (a frame leaves the encoder as soon as it is in). On the
#: same frames: 2.9 ms a frame against the file's 6.8 (headroom on two cores), 6.1 MB (a
#: pipe or the page on this machine, not a network), PSNR 48.4 dB. Not ``-tune
#: zerolatency``: the same size, PSNR and CPU, but with the sound on its second pipe, ffmpeg
#: (n9.0.2) stopped reading both pipes for good once the frames came slower than real time
#: (360x288 and 1280x720 alike; ``ultrafast`` alone never did). Its frames decode to other
#: bytes than the file's (45 dB from them on a 720p say). ``say -o -`` and ``dub -o -`` use it
#: too: on 2 minutes of a 720p say, ffmpeg and Festival took 13.5 s of CPU against the
#: file's 27.3 s (the whole run 41.0 against 55.5 s; docs/serve.md, "An hour's text").
LIVE_X264 = X264("ultrafast", 20)


def ffmpeg_exe() -> str:
    """Path of the ffmpeg binary bundled with imageio-ffmpeg.

    Raises
    ------
    MiketalkError
        If imageio-ffmpeg or its binary is missing.
    """
    try:
        import imageio_ffmpeg

        return imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError) as exc:
        raise MiketalkError(
            f"ffmpeg not found ({exc}); reinstall miketalk's dependencies "
            "(pip install imageio-ffmpeg)"
        ) from exc
