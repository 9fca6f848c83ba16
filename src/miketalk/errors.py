"""The one exception type for mistakes a user can make, its kind for a failing machine, and its
kind for a setting (named as the library spells it, each front end naming it its own way)."""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping


class MiketalkError(Exception):
    """A user-facing error: bad input, a missing file or tool, a bad setting.

    The message says what went wrong and, where it can, what to do about it.
    The CLI and workflow scripts print it without a traceback.
    """


class MachineFailure(MiketalkError):
    """A failure of the machine, not a mistake of the user: a full disk, a process killed when
    memory ran out. The command line prints it in one line, with exit status 1 (2 is for bad
    input)."""


class SettingError(MiketalkError):
    """A setting that is out of range or does not go with another: the message names each
    setting as the library spells it, ``{max_px_per_frame}`` in ``template``.

    ``str(err)`` names them so (``max_px_per_frame``); a front end names them as its user
    knows them with :meth:`render` (the command line its flags, the page its form fields).
    """

    def __init__(self, template: str) -> None:
        self.template = template
        super().__init__(self.render())

    @property
    def settings(self) -> tuple[str, ...]:
        """The settings the message names, in order."""
        return tuple(dict.fromkeys(_SETTING.findall(self.template)))

    def render(self, names: Mapping[str, str] | Callable[[str], str] | None = None) -> str:
        """The message with each setting named by ``names`` (a mapping or a function of the
        library's name; a name it does not know stays the library's)."""
        if names is None:
            name = str
        elif callable(names):
            name = names
        else:
            name = lambda setting: names.get(setting, setting)  # noqa: E731
        return _SETTING.sub(lambda match: name(match[1]), self.template)


#: A setting's name in a :class:`SettingError`'s template.
_SETTING = re.compile(r"\{([a-z][a-z_]*)\}")
