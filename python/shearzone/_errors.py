"""The exceptions of shearzone: each carries the command's one-line message."""


class ShearzoneError(Exception):
    """Base class of every error shearzone raises on purpose."""


class InputError(ShearzoneError, ValueError):
    """Bad input data: a file missing, unreadable or malformed, a value out of range
    (the command's exit code 2)."""


class MissingFileError(InputError, FileNotFoundError):
    """An input file that does not exist."""


class ConfigError(ShearzoneError, ValueError):
    """Bad options: a value out of range, an unknown keyword, an inconsistent
    combination, an output that exists without force=True (exit code 2)."""


class NoResultError(ShearzoneError, RuntimeError):
    """The work ran but gave nothing usable (exit code 3)."""


class InternalError(ShearzoneError, RuntimeError):
    """A broken invariant: a bug in shearzone, never the user's fault (exit code 4)."""


class NoResultWarning(UserWarning):
    """The work ran and wrote its table, but no row holds a usable result (the command's
    exit code 3): each row's status says why (width)."""
