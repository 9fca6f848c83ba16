"""The Festival voices miketalk speaks with: the ones Debian packages in the radio phone set.

Every voice here uses Festival's US English ``radio`` phone set, the one the
viseme table (``data/phones.tsv``) maps. They differ in how they make sound:

``kal`` (``festvox-kallpc16k``)
    Kal, a male diphone voice; the default. Festival's Segment durations are
    what it speaks, so dictated durations (the paper's oversampling) are kept
    to the microsecond.
``ked`` (``festvox-kdlpc16k``)
    Ked, another male diphone voice, the same way.
``slt`` (``festvox-us-slt-hts``)
    SLT, a female HMM (HTS) voice from CMU ARCTIC, far more natural. Its
    synthesis sets the phone durations itself and ignores dictated ones, so
    it cannot be oversampled by lengthening speech; motion blur (the default
    sampling) keeps it smooth instead.
"""

from __future__ import annotations

from dataclasses import dataclass

from miketalk.errors import MiketalkError


@dataclass(frozen=True)
class Voice:
    """A Festival voice.

    Attributes
    ----------
    name : str
        miketalk's short name (``--voice``).
    function : str
        The Scheme function that selects it in Festival.
    package : str
        The Debian package that installs it.
    rate : int
        Sample rate of its waves, Hz.
    follows_durations : bool
        Whether it speaks Segment durations dictated before ``Wave_Synth``.
    description : str
        One line for ``--help``.
    """

    name: str
    function: str
    package: str
    rate: int
    follows_durations: bool
    description: str


VOICES: dict[str, Voice] = {
    v.name: v
    for v in (
        Voice("kal", "voice_kal_diphone", "festvox-kallpc16k", 16000, True, "male, diphone"),
        Voice("ked", "voice_ked_diphone", "festvox-kdlpc16k", 16000, True, "male, diphone"),
        Voice(
            "slt",
            "voice_cmu_us_slt_arctic_hts",
            "festvox-us-slt-hts",
            32000,
            False,
            "female, HTS (most natural; sets its own durations)",
        ),
    )
}

DEFAULT_VOICE = "kal"


def get_voice(name: str) -> Voice:
    """The voice called ``name`` (miketalk's short name or Festival's function name).

    Raises
    ------
    MiketalkError
        For a voice miketalk does not know, listing the known ones.
    """
    for voice in VOICES.values():
        if name in (voice.name, voice.function):
            return voice
    known = ", ".join(f"{v.name} ({v.package})" for v in VOICES.values())
    raise MiketalkError(f"unknown voice {name!r}; known: {known}")


def install_hint(voice: Voice) -> str:
    """The apt-get line that installs Festival and ``voice``."""
    return f"install it with: apt-get install -y festival {voice.package}"
