"""The one exception type for mistakes a user can make."""


class MiketalkError(Exception):
    """A user-facing error: bad input, a missing file or tool, a bad setting.

    The message says what went wrong and, where it can, what to do about it.
    The CLI and workflow scripts print it without a traceback.
    """
