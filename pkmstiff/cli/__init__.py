"""Command-line interface ``pkmstiff`` (lengths in mm and angles in degrees on the command line)."""

from __future__ import annotations

import argparse
import importlib
import os
import re
import sys
from typing import Sequence

from pkmstiff import __version__
from pkmstiff.errors import ArgumentError, InadmissibleError, InputError, NumericalError, PkmstiffError, ResourceError

# modules that add their own sub-commands with ``add_commands(subparsers)``
_COMMAND_MODULES = ("pkmstiff.cli.machines", "pkmstiff.cli.components", "pkmstiff.cli.demo", "pkmstiff.cli.pose",
                    "pkmstiff.cli.point", "pkmstiff.cli.section", "pkmstiff.cli.workspace", "pkmstiff.cli.report",
                    "pkmstiff.cli.sweep", "pkmstiff.cli.fe", "pkmstiff.cli.ballbar",
                    "pkmstiff.cli.calibrate", "pkmstiff.cli.mechanism", "pkmstiff.cli.optimise",
                    "pkmstiff.cli.app")


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (the usage is not repeated: ``pkmstiff COMMAND --help`` shows it) and without
    option abbreviations (``--pos`` for ``--pose`` would change meaning whenever an option is added)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str):  # type: ignore[override]
        raise ArgumentError(f"{message} (see '{self.prog} --help')")


#: a value that starts like a negative number: "-100", "-.5", "-100,300,-1000,0,0,0", "-30,30"
_NEGATIVE_VALUE = re.compile(r"^-(\d|\.\d)")


def _value_options(parser: argparse.ArgumentParser) -> set[str]:
    """Every long option (of the parser and its sub-parsers) that takes a value."""
    out: set[str] = set()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                out |= _value_options(sub)
        elif action.option_strings and action.nargs != 0:
            out.update(o for o in action.option_strings if o.startswith("--"))
    return out


def join_negative_values(argv: Sequence[str], value_options: set[str]) -> list[str]:
    """``--pose -100,300,-1000,0,0,0`` -> ``--pose=-100,300,-1000,0,0,0``: argparse would take a value that starts
    with '-' (and is not a plain negative number) for an option, so negative vectors are joined to their option."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        tok = argv[i]
        if tok in value_options and i + 1 < len(argv) and _NEGATIVE_VALUE.match(argv[i + 1]):
            out.append(f"{tok}={argv[i + 1]}")
            i += 2
            continue
        out.append(tok)
        i += 1
    return out


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``pkmstiff`` parser with every command, or (``command`` given and a command module of that name exists)
    only that command's module: ``pkmstiff pose ...`` then imports neither the FE, calibration nor plotting commands'
    modules (start-up time, issue 12 item 6)."""
    parser = _Parser(
        prog="pkmstiff",
        description="Stiffness, vibration and workspace analysis of parallel-kinematic machines "
                    "(command line: lengths in mm, angles in degrees).",
    )
    parser.add_argument("--version", action="version", version=f"pkmstiff {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    modules = _COMMAND_MODULES
    if command and f"pkmstiff.cli.{command}" in _COMMAND_MODULES:
        modules = (f"pkmstiff.cli.{command}",)
    for modname in modules:
        try:
            mod = importlib.import_module(modname)
        except ModuleNotFoundError as exc:
            if exc.name and modname.startswith(exc.name):  # module not part of this installation
                continue
            raise
        mod.add_commands(sub)
    return parser


def _subcommands(parser: argparse.ArgumentParser) -> set[str]:
    return {name for a in parser._actions if isinstance(a, argparse._SubParsersAction) for name in a.choices}


def _headless() -> None:
    """Choose VTK's EGL window when there is no display (the edge decides the rendering back-end)."""
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")


#: exit status after a closed output pipe (``pkmstiff point ... | head``): 128 + SIGPIPE, as a shell reports a
#: process ended by SIGPIPE
EXIT_BROKEN_PIPE = 141


#: the command line's exit status for each error kind (the one place that maps kinds to statuses)
EXIT_STATUS: dict[type[PkmstiffError], int] = {InputError: 2, ArgumentError: 2, ResourceError: 2, NumericalError: 2,
                                               InadmissibleError: 3, PkmstiffError: 2}


def exit_status(exc: PkmstiffError) -> int:
    """The exit status of ``exc``: that of its nearest kind in :data:`EXIT_STATUS`."""
    return next(EXIT_STATUS[k] for k in type(exc).__mro__ if k in EXIT_STATUS)


def _command_of(argv: Sequence[str]) -> str:
    return next((a for a in argv if not a.startswith("-")), "")


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``pkmstiff ARGS`` and return the exit status.

    0 success; 2 bad input or a usage error (one line ``pkmstiff COMMAND: error: ...`` on stderr, no traceback);
    3 an inadmissible or unreachable pose or plan (:class:`~pkmstiff.errors.InadmissibleError`); 1 an internal error
    (a bug: one line, the traceback with ``PKMSTIFF_TRACEBACK=1``); 130 interrupted; 141 output pipe closed. The
    statuses of the error kinds are :data:`EXIT_STATUS`.
    """
    from pkmstiff.evaluation.parallel import steady_malloc

    _headless()
    steady_malloc()
    argv = list(sys.argv[1:] if argv is None else argv)
    command = _command_of(argv)
    try:
        parser = build_parser(command)
        if command and command not in _subcommands(parser):  # a module registering other names: all of them
            parser = build_parser()
        args = parser.parse_args(join_negative_values(argv, _value_options(parser)))
        command = getattr(args, "command", None) or command
        if not getattr(args, "func", None):
            parser.print_help()
            return 0
        return int(args.func(args) or 0)
    except PkmstiffError as exc:
        return _fail(command, str(exc), exit_status(exc))
    except BrokenPipeError:
        _silence_stdout()
        return EXIT_BROKEN_PIPE
    except KeyboardInterrupt:
        return _fail(command, "interrupted", 130)
    except UnicodeDecodeError as exc:
        return _fail(command, f"input is not UTF-8 text (byte 0x{exc.object[exc.start]:02x} at offset {exc.start})", 2)
    except MemoryError:
        return _fail(command, "out of memory: use a coarser step/resolution or a smaller region", 2)
    except OSError as exc:
        where = f": {exc.filename}" if exc.filename else ""
        return _fail(command, f"{exc.strerror or exc}{where}", 2)
    except Exception as exc:  # a bug: one line unless asked for the traceback
        if os.environ.get("PKMSTIFF_TRACEBACK"):
            raise
        return _fail(command, f"internal error {type(exc).__name__}: {exc} (please report it; "
                              f"PKMSTIFF_TRACEBACK=1 shows the traceback)", 1)


def _fail(command: str, message: str, status: int) -> int:
    message = " ".join(str(message).split())  # exactly one line
    try:
        print(f"pkmstiff{' ' + command if command else ''}: error: {message}", file=sys.stderr)
    except BrokenPipeError:  # pragma: no cover
        pass
    return status


def _silence_stdout() -> None:
    """After EPIPE, point stdout at /dev/null so that the interpreter's final flush does not fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # stdout without a file descriptor (tests)
        pass


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
