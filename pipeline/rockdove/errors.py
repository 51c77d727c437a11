"""Exceptions that the CLI turns into exit statuses (any ``ValueError``, as bad usage, exits 2)."""


class RockdoveError(Exception):
    """Base class of rockdove's own errors."""


class UsageError(RockdoveError, ValueError):
    """Bad arguments, configuration or input: the message names what was wrong. CLI exit status 2."""


class VerificationFailed(RockdoveError):
    """An asset failed validation or verification. CLI exit status 1."""


class ResourceMissing(RockdoveError, FileNotFoundError):
    """A data file the package needs (shader, schema, preset) is not installed. CLI exit status 2, one line."""
