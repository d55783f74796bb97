"""``pkmstiff app``: the local browser app (issue 28 item 3; needs the optional extra ``app``: trame)."""

from __future__ import annotations

import argparse
from typing import Any

from pkmstiff.errors import ArgumentError, ResourceError


def _cmd_app(args: argparse.Namespace) -> int:
    if not 0 <= args.port <= 65535:
        raise ArgumentError(option="--port", expected="a port 0..65535 (0: a free one)", found=args.port)
    from pathlib import Path

    from pkmstiff.app.session import STEP_LIMITS_MM

    lo, hi = STEP_LIMITS_MM
    if not lo <= args.step <= hi:
        raise ArgumentError(option="--step", expected=f"a raster step {lo:g}..{hi:g} mm", found=args.step)

    if Path(args.out).exists() and not Path(args.out).is_dir():
        raise ArgumentError(option="--out", expected="a directory for the exports (made on the first export)",
                            found=args.out)
    try:
        import trame  # noqa: F401
        import trame_vtk  # noqa: F401
        import trame_vuetify  # noqa: F401
    except ImportError as exc:
        raise ResourceError(f"pkmstiff app needs trame ({exc.name} is not installed): "
                            f"pip install 'pkmstiff[app]'") from None
    from pkmstiff.app.mechanisms import elastic_mechanism
    from pkmstiff.app.session import MachineChoice, Session, is_mechanism_target
    from pkmstiff.app.ui import App

    # a bad machine name or file, a mechanism without [elastic]: one line before serving
    if is_mechanism_target(args.machine):
        elastic_mechanism(Session().mechanism(args.machine))
    else:
        Session().machine(MachineChoice(args.machine))
    App(args.machine, out=args.out, step_mm=args.step).start(port=args.port, open_browser=not args.no_browser)
    return 0


def add_commands(sub: Any) -> None:
    p = sub.add_parser("app", help="explore a machine in a local browser app (3-D pose, section maps, point "
                                   "analysis, export)",
                       description="A browser app served on 127.0.0.1 only (no network): pick a machine and a "
                                   "variant, drag its pose, see section maps of any quantity, click a point for its "
                                   "stiffness, weak points and modes, export PNG, CSV and the commands. Stop with "
                                   "Ctrl+C. Needs the optional extra 'app' (trame).")
    p.add_argument("machine", nargs="?", default="hexaglide",
                   help="bundled machine name or machine file, or a mechanism with an [elastic] table, to start "
                        "with (default hexaglide)")
    p.add_argument("--port", type=int, default=8080, help="port on 127.0.0.1 (default 8080; 0: a free port)")
    p.add_argument("--out", default="pkmstiff-app",
                   help="export directory: each export goes into a new folder export-NNN in it (default pkmstiff-app)")
    p.add_argument("--step", type=float, default=25.0,
                   help="raster step of the first section map [mm] (default 25; changed in the app)")
    p.add_argument("--no-browser", action="store_true", help="do not open the system browser (print the URL only)")
    p.set_defaults(func=_cmd_app)
