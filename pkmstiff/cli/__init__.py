"""Command-line interface ``pkmstiff`` (lengths in mm and angles in degrees on the command line)."""

from __future__ import annotations

import argparse
import importlib
import json
import os
import sys
from typing import Sequence

from pkmstiff import __version__
from pkmstiff.errors import CliError, PkmstiffError  # noqa: F401 (CliError re-exported)

# modules that add their own sub-commands with ``add_commands(subparsers)``
_COMMAND_MODULES = ("pkmstiff.cli.machines", "pkmstiff.cli.components", "pkmstiff.cli.demo", "pkmstiff.cli.pose",
                    "pkmstiff.cli.point", "pkmstiff.cli.section", "pkmstiff.cli.workspace", "pkmstiff.cli.report",
                    "pkmstiff.cli.sweep", "pkmstiff.cli.fe", "pkmstiff.cli.ballbar",
                    "pkmstiff.cli.calibrate")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pkmstiff",
        description="Stiffness, vibration and workspace analysis of parallel-kinematic machines "
                    "(command line: lengths in mm, angles in degrees).",
    )
    parser.add_argument("--version", action="version", version=f"pkmstiff {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for modname in _COMMAND_MODULES:
        try:
            mod = importlib.import_module(modname)
        except ModuleNotFoundError as exc:
            if exc.name and modname.startswith(exc.name):  # module not part of this installation
                continue
            raise
        mod.add_commands(sub)
    return parser


def _headless() -> None:
    """Choose VTK's EGL window when there is no display (the edge decides the rendering back-end)."""
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``pkmstiff ARGS``; a toolkit error (:class:`~pkmstiff.errors.PkmstiffError`) prints one line, exit 2."""
    _headless()
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    try:
        return int(args.func(args) or 0)
    except PkmstiffError as exc:
        print(f"pkmstiff {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
