"""The closed vocabularies, ranges and defaults the front ends offer as choices, from their one
home each (standard library only: the command line's parser reads them)."""

from __future__ import annotations

from miketalk.building.frame import CONVERSIONS, CROP, FRAMES, FULL
from miketalk.defaults import FPS, HELDOUT_SECONDS, MAX_PX_PER_FRAME
from miketalk.errors import MachineFailure, MiketalkError, SettingError
from miketalk.lipsync.settings import (
    FPS_RANGE,
    LIPSYNC_MODELS,
    MAX_PX_RANGE,
    SAMPLINGS,
    TRAJECTORIES,
    check_fps,
    check_max_px,
    check_max_slowdown,
)
from miketalk.speech.festival.voices import DEFAULT_VOICE, VOICES

__all__ = [
    "CONVERSIONS",
    "CROP",
    "DEFAULT_VOICE",
    "FPS",
    "FPS_RANGE",
    "FRAMES",
    "FULL",
    "HELDOUT_SECONDS",
    "LIPSYNC_MODELS",
    "MAX_PX_PER_FRAME",
    "MAX_PX_RANGE",
    "SAMPLINGS",
    "TRAJECTORIES",
    "VOICES",
    "MachineFailure",
    "MiketalkError",
    "SettingError",
    "check_fps",
    "check_max_px",
    "check_max_slowdown",
]
