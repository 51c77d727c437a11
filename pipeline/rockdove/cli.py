"""The ``rockdove`` command line. Each of :data:`COMMANDS` is ``rockdove/commands/<name>.py`` (imported only when
it runs) with ``add_arguments(parser)`` and ``run(args) -> exit status``. Errors are one line on stderr
(:mod:`rockdove.errors`): :class:`~rockdove.errors.RockdoveError` and ``OSError`` exit 2,
:class:`~rockdove.errors.VerificationFailed` 1; any other exception is a bug and shows its traceback."""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import signal
import sys

from . import __version__
from .errors import RockdoveError, VerificationFailed, raise_interrupt
from .resources import spare_full_disk

COMMANDS: dict[str, str] = {
    "build": "build the pigeon USD asset (incremental; verifies unless --no-verify)",
    "lut": "bake a thin-film colour LUT over angle and thickness into OpenEXR",
    "render": "render an asset offscreen with the GLSL shaders (pyrender, EGL)",
    "verify": "validate an asset and check its renders against the exact spectral reference",
    "validate": "validate a USD asset (UsdValidation + MaterialX node definitions + textures)",
    "gltf": "export an asset to glTF 2.0 (pigeon.glb, KHR_materials_iridescence) and validate it",
    "bench": "benchmarks: LUT bake speed against error, geometry and build scaling",
    "config": "print the effective build configuration with units",
    "schema-path": "print the folder holding the USD schema plugin, for PXR_PLUGINPATH_NAME",
    "blender-addon": "write the Blender add-on (rockdove_blender.zip) that builds the thin-film material on USD import",
    "sweep": "build (and verify) every point of a parameter grid on Dask (a local cluster or --scheduler)",
}


class _Parser(argparse.ArgumentParser):
    """Errors in one line, exit status 2."""

    def error(self, message: str):
        self.exit(2, f"rockdove: error: {message}\n")


def _module(name: str):
    return importlib.import_module(f"rockdove.commands.{name.replace('-', '_')}")


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The top-level parser; only ``command``'s module is imported to add its arguments."""
    parser = _Parser(prog="rockdove", description="Build, render and verify a USD rock dove whose neck feathers "
                                                  "shimmer by thin-film interference.")
    parser.add_argument("--version", action="version", version=f"rockdove {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name, help_ in COMMANDS.items():
        p = sub.add_parser(name, help=help_, description=help_)
        if name == command:
            _module(name).add_arguments(p)
    return parser


def main(argv: list[str] | None = None) -> int:
    """The ``rockdove`` console script: the exit status of the command of ``argv``."""
    spare_full_disk()
    argv = list(sys.argv[1:] if argv is None else argv)
    command = next((a for a in argv if not a.startswith("-")), None)
    parser = build_parser(command if command in COMMANDS else None)
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    _log_to_stderr(args.command, quiet=bool(getattr(args, "quiet", False) or getattr(args, "json", False)))
    old_term = signal.signal(signal.SIGTERM, raise_interrupt)  # as Ctrl-C: jobs end, temporaries go
    try:
        return int(_module(args.command).run(args) or 0)
    except VerificationFailed as exc:
        print(f"rockdove {args.command}: failed: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"rockdove {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader of stdout went away (`rockdove ... | head`): no traceback
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # so the final flush is quiet too
        os.close(devnull)
        return 141
    except (RockdoveError, OSError) as exc:  # bad usage, or the machine said no (a full disk): one line, exit 2
        if os.environ.get("ROCKDOVE_DEBUG"):
            raise
        if not isinstance(exc, (RockdoveError, FileNotFoundError, IsADirectoryError, NotADirectoryError,
                                PermissionError)):
            exc = f"{exc.strerror or exc}" + (f": {exc.filename}" if exc.filename else "")
        print(f"rockdove {args.command}: error: {exc}", file=sys.stderr)
        return 2
    finally:
        signal.signal(signal.SIGTERM, old_term)


def _log_to_stderr(command: str, quiet: bool) -> None:
    """The library reports through the ``rockdove`` logger; the command line shows its messages on stderr as
    ``rockdove COMMAND: message`` (``--quiet`` and ``--json``: warnings and errors only)."""
    logger = logging.getLogger("rockdove")
    logger.handlers.clear()
    handler = logging.StreamHandler()
    handler.setFormatter(logging.Formatter(f"rockdove {command}: %(message)s"))
    logger.addHandler(handler)
    logger.setLevel(logging.WARNING if quiet else logging.INFO)

if __name__ == "__main__":
    sys.exit(main())
