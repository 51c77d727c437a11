"""Exceptions that the CLI turns into exit statuses.

- :class:`UsageError` (a ``ValueError``): bad arguments, configuration or input. Exit status 2, one line.
- :class:`VerificationFailed`: an asset was checked and failed validation or verification. Exit status 1.

Library functions raise plain ``ValueError`` for bad arguments (naming the argument, its value and what
is allowed); the CLI treats every ``ValueError`` like a :class:`UsageError`.
"""


class RockdoveError(Exception):
    """Base class of rockdove's own errors."""


class UsageError(RockdoveError, ValueError):
    """Bad arguments, configuration or input: the message names what was wrong. CLI exit status 2."""


class VerificationFailed(RockdoveError):
    """An asset failed validation or verification. CLI exit status 1."""


class ResourceMissing(RockdoveError, FileNotFoundError):
    """A data file the package needs (shader, schema, preset) is not installed. CLI exit status 2, one line."""
