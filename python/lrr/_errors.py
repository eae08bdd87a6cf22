"""The exceptions of lrr, by who must act (the runtime's two kinds, and a failed command)."""


class LrrError(Exception):
    """Base class of every error lrr raises."""


class FormatError(LrrError):
    """The operator file cannot be read or is invalid (missing, not an lrr file, another
    version, truncated, corrupt). ``kind`` names which, e.g. ``"not an lrr file"``."""

    def __init__(self, message: str, kind: str = "") -> None:
        super().__init__(message)
        self.kind = kind


class InputError(LrrError, ValueError):
    """A call cannot be done as asked: an array of the wrong shape or dtype, a NaN or negative
    emission, a reflectance of 1, a light group that does not exist."""


class CommandError(LrrError):
    """A command of the ``lrr`` command line run from Python (bake, export) failed; the message
    is the command's one line ``what: why``."""
