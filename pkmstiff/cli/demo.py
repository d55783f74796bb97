"""``pkmstiff demo``: the main job on the bundled Hexaglide (maps, three-plane figure, summary)."""

from __future__ import annotations

import argparse


def _cmd_demo(args: argparse.Namespace) -> int:
    import math

    from pkmstiff.cli.edges import check_output_dir
    from pkmstiff.errors import ArgumentError
    from pkmstiff.report import demo

    if not (math.isfinite(args.step) and 1.0 <= args.step <= 100.0):
        raise ArgumentError(f"--step: expected a raster step of 1 to 100 mm, found {args.step:g}")
    check_output_dir(args.out, "--out", getattr(args, "force", False), tuple(demo.output_files()))

    return int(demo.run(args))


def add_commands(sub) -> None:
    p = sub.add_parser("demo", help="run the demo on the bundled Hexaglide")
    p.add_argument("--out", default="out/demo", help="output directory (default out/demo)")
    p.add_argument("--step", type=float, default=10.0, help="raster step of the YZ maps [mm] (default 10)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("--force", action="store_true", help="overwrite an earlier demo in --out")
    p.set_defaults(func=_cmd_demo)
