"""miketalk's public API: one call per use case, each with one typed settings object and a
typed result (docs/api.md).

- :func:`say`: a text or a recording (:class:`Recorded`) to an mp4 of the model's face
  speaking it (:class:`SaySettings`, :class:`SayResult`), or a fragmented MP4 on a pipe;
  :func:`say_stream`: the same as a stream of timed chunks (a frame and its sound at a
  time, a bounded queue, cancellable);
- :func:`dub`: a video of the model's person made to say new speech (:class:`DubSettings`,
  :class:`DubResult`); :func:`dub_stream` as a stream; :func:`own_model`: a video's own
  model, built once and kept by its checksum (a dub given no model;
  :func:`miketalk.api.video_model.video_model`);
- :func:`build`: a model from one video of a person and what it says
  (:class:`BuildSettings`, :class:`BuildResult`);
- :func:`cues`: the mouth cues of a text or a recording (:class:`CuesSettings`,
  :class:`CuesResult`).

Each checks everything once, before its work where it can, and raises one
:class:`~miketalk.errors.MiketalkError` line; a :class:`~miketalk.errors.SettingError` names
the settings as spelled here, for the command line and the page to name as their users know
them. :class:`OpenModels` keeps models open between calls. The command line (:mod:`miketalk.cli`)
and the page (:mod:`miketalk.serve`) call nothing else of the library
(``tests/test_layout.py``).
"""

from miketalk.api.build import build, list_model_files, sweep_build
from miketalk.api.cues import cues, phones
from miketalk.api.dub import dub, dub_stream
from miketalk.api.models import (
    ModelInfo,
    OpenModels,
    describe_model,
    is_model,
    load_engine,
    model_picture,
)
from miketalk.api.results import BuildResult, CuesResult, DubResult, SayResult
from miketalk.api.say import Recorded, check, say, say_stream, write_fragmented
from miketalk.api.settings import BuildSettings, CuesSettings, DubSettings, SaySettings
from miketalk.api.video_model import video_model as own_model
from miketalk.errors import MachineFailure, MiketalkError, SettingError
from miketalk.model.parts import workflow_results
from miketalk.speech.text import read_text_file
from miketalk.talk.stream import QUEUE_CHUNKS, Cancelled, Chunk, Stream, StreamInfo

__all__ = [
    "QUEUE_CHUNKS",
    "BuildResult",
    "BuildSettings",
    "Cancelled",
    "Chunk",
    "CuesResult",
    "CuesSettings",
    "DubResult",
    "DubSettings",
    "MachineFailure",
    "MiketalkError",
    "ModelInfo",
    "OpenModels",
    "Recorded",
    "SayResult",
    "SaySettings",
    "SettingError",
    "Stream",
    "StreamInfo",
    "build",
    "check",
    "cues",
    "describe_model",
    "dub",
    "dub_stream",
    "is_model",
    "list_model_files",
    "load_engine",
    "model_picture",
    "own_model",
    "phones",
    "read_text_file",
    "say",
    "say_stream",
    "sweep_build",
    "workflow_results",
    "write_fragmented",
]
