"""The exceptions femto raises: each carries the command line's one-line message."""


class FemtoError(ValueError):
    """A stage refused its input: a bad argument, a malformed file, an impossible setting.

    ``str(e)`` is the line ``femto`` prints after ``femto: error:``, naming the file, key or
    flag (with the keyword argument's name in CLI form, e.g. ``--dolly``).
    """


class FemtoOSError(FemtoError, OSError):
    """A file or folder could not be opened, read, written or renamed (``errno`` is set)."""


class FemtoFileNotFoundError(FemtoOSError, FileNotFoundError):
    """A file or folder that a stage reads does not exist."""
