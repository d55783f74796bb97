"""``pkmstiff demo``: the main job on the bundled Hexaglide (maps, three-plane figure, summary)."""

from __future__ import annotations

import argparse


def _cmd_demo(args: argparse.Namespace) -> int:
    from pkmstiff.report import demo

    return int(demo.run(args))


def add_commands(sub) -> None:
    p = sub.add_parser("demo", help="run the demo on the bundled Hexaglide")
    p.add_argument("--out", default="out/demo", help="output directory (default out/demo)")
    p.add_argument("--step", type=float, default=10.0, help="raster step of the YZ maps [mm] (default 10)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=_cmd_demo)
