"""The server's state: its settings, the models it lists, the uploads waiting, the jobs."""

from __future__ import annotations

from typing import Any

from miketalk import __version__
from miketalk.api.vocabulary import DEFAULT_VOICE, LIPSYNC_MODELS, VOICES
from miketalk.serve.build import BUILD_STAGES
from miketalk.serve.catalog import Catalog
from miketalk.serve.config import MAX_TEXT_CHARS, MAX_TEXT_WORDS, ServeConfig
from miketalk.serve.jobs import Board
from miketalk.serve.uploads import Uploads


class App:
    """The server's state: its settings, models, uploads and jobs.

    Parameters
    ----------
    config : ServeConfig
    """

    def __init__(self, config: ServeConfig) -> None:
        self.config = config
        self.catalog = Catalog(config.models, config.known_models, workflow=config.workflow)
        self.uploads = Uploads(config.uploads, config.max_upload_bytes)
        self.board = Board(config, self.catalog)

    def settings(self) -> dict[str, Any]:
        """What the page needs to know before it asks for anything."""
        return {
            "version": __version__,
            "max_upload_bytes": self.config.max_upload_bytes,
            "max_text_chars": MAX_TEXT_CHARS,
            "max_text_words": MAX_TEXT_WORDS,
            "voices": [{"name": v.name, "description": v.description} for v in VOICES.values()],
            "default_voice": DEFAULT_VOICE,
            "lipsync_models": list(LIPSYNC_MODELS),
            "build_stages": list(BUILD_STAGES),
        }

    def close(self) -> None:
        """Stop the jobs' threads (a running job is stopped)."""
        self.board.close()
