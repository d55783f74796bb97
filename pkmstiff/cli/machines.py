"""``pkmstiff machines``: the bundled machines, one line each."""

from __future__ import annotations

import argparse
import json

from pkmstiff.machine.loader import bundled_machines, load_machine


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


def add_commands(sub) -> None:
    p = sub.add_parser("machines", help="list the bundled machines, one line each")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_machines)
