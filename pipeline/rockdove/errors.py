"""rockdove's exceptions: every one it raises on purpose derives from :class:`RockdoveError`.

The CLI prints a :class:`RockdoveError` as one line (exit 1 for :class:`VerificationFailed`, else 2), and an
``OSError`` too (the machine said no: a full disk, a read-only folder); anything else is a bug and keeps its
traceback. ``ROCKDOVE_DEBUG=1`` shows the traceback of every error."""


class RockdoveError(Exception):
    """Base class of rockdove's own errors."""


class UsageError(RockdoveError, ValueError):
    """Bad arguments, configuration or input: the message names what was wrong, its value and what is allowed."""


class VerificationFailed(RockdoveError):
    """An asset failed validation or verification. CLI exit status 1."""


class ResourceMissing(RockdoveError, FileNotFoundError):
    """A data file the package needs (shader, schema, preset) is not installed."""


def raise_interrupt(signum, frame):
    """The SIGTERM handler of the CLI and :func:`rockdove.api.build`: a supervisor stops rockdove as Ctrl-C does."""
    raise KeyboardInterrupt(f"signal {signum}")
