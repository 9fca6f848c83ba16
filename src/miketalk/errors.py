"""The one exception type for mistakes a user can make, and its kind for a failing machine."""


class MiketalkError(Exception):
    """A user-facing error: bad input, a missing file or tool, a bad setting.

    The message says what went wrong and, where it can, what to do about it.
    The CLI and workflow scripts print it without a traceback.
    """


class MachineFailure(MiketalkError):
    """A failure of the machine, not a mistake of the user: a full disk, a process killed when
    memory ran out. The command line prints it in one line, with exit status 1 (2 is for bad
    input)."""
