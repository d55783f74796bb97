"""Command-line interface ``pkmstiff`` (lengths in mm and angles in degrees on the command line)."""

from __future__ import annotations

import argparse
import importlib
import json
import sys
from typing import Sequence

from pkmstiff import __version__
from pkmstiff.machine.loader import MachineFileError, UnknownMachineError, bundled_machines, load_machine
from pkmstiff.units import InputError

# modules that add their own sub-commands with ``add_commands(subparsers)``
_COMMAND_MODULES = ("pkmstiff.cli.pose", "pkmstiff.cli.point", "pkmstiff.cli.section", "pkmstiff.cli.workspace", "pkmstiff.cli.report", "pkmstiff.cli.sweep",
                    "pkmstiff.cli.fe", "pkmstiff.cli.mechanism")


class CliError(Exception):
    """A user error on the command line; printed without traceback, exit code 2."""


def _cmd_machines(args: argparse.Namespace) -> int:
    rows = []
    for name in bundled_machines():
        m = load_machine(name)
        rows.append({"name": name, "type": m.kind, "chains": m.n_chains, "title": m.title,
                     "assumptions": len(m.assumptions)})
    if args.json:
        print(json.dumps(rows, indent=2))
    else:
        width = max(len(r["name"]) for r in rows)
        for r in rows:
            print(f"{r['name']:<{width}}  {r['type']:<5}  {r['title']}  ({r['assumptions']} assumptions)")
    return 0


def _cmd_components(args: argparse.Namespace) -> int:
    from components.registry import available_models, model_info

    models = available_models()
    if args.model:
        if args.model not in models:
            raise CliError(f"unknown component model {args.model!r}; expected one of {', '.join(sorted(models))}")
        info = model_info(args.model)
        print(f"{args.model}: {models[args.model]}")
        for p in info.parameters:
            print(f"  {p.key:<40} [{p.unit}] default {p.default}: {p.meaning}")
        return 0
    if args.json:
        print(json.dumps(models, indent=2))
        return 0
    width = max(map(len, models))
    for name, desc in sorted(models.items()):
        print(f"{name:<{width}}  {desc}")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    import pkmstiff.report.demo as demo
    return int(demo.run(args))


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pkmstiff",
        description="Stiffness, vibration and workspace analysis of parallel-kinematic machines "
                    "(command line: lengths in mm, angles in degrees).",
    )
    parser.add_argument("--version", action="version", version=f"pkmstiff {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    p = sub.add_parser("machines", help="list the bundled machines, one line each")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_machines)
    p = sub.add_parser("components", help="list the component models (or the parameters of one)")
    p.add_argument("model", nargs="?", help="show the parameters of this model")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_components)
    p = sub.add_parser("demo", help="run the demo on the bundled Hexaglide")
    p.add_argument("--out", default="out/demo", help="output directory (default out/demo)")
    p.add_argument("--step", type=float, default=10.0, help="raster step of the YZ maps [mm] (default 10)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=_cmd_demo)
    for modname in _COMMAND_MODULES:
        try:
            mod = importlib.import_module(modname)
        except ModuleNotFoundError as exc:
            if exc.name and modname.startswith(exc.name):  # module not part of this installation
                continue
            raise
        mod.add_commands(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    try:
        return int(args.func(args) or 0)
    except (MachineFileError, UnknownMachineError, InputError, CliError) as exc:
        print(f"pkmstiff {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
