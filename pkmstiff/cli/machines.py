"""``pkmstiff machines``: the bundled machines, one line each; ``pkmstiff machines NAME``: one machine's options,
assumptions and components."""

from __future__ import annotations

import argparse
import json

from pkmstiff.machine.loader import bundled_machines, load_machine, machine_options, raw_machine


def machine_info(name: str) -> dict:
    """Options (with their descriptions where the file gives one), assumptions and components of a machine."""
    m = load_machine(name)
    _, src, _ = raw_machine(name)
    options = machine_options(name)
    comps = {}
    for cname, cdata in m.components.items():
        comps[cname] = str(cdata.get("model", "")) if isinstance(cdata, dict) else ""
    roles = dict(m.machine_components)
    for i, ch in enumerate(m.chain_components):
        for role, cname in ch.items():
            roles.setdefault(f"chain {i + 1} {role}", cname)
    return {"name": m.name, "title": m.title, "type": m.kind, "chains": m.n_chains, "file": src,
            "options": options, "assumptions": dict(m.assumptions), "components": comps, "roles": roles}


def _cmd_machines(args: argparse.Namespace) -> int:
    if args.name:
        info = machine_info(args.name)
        if args.json:
            print(json.dumps(info, indent=2))
            return 0
        print(f"{info['name']}: {info['title']} ({info['type']}, {info['chains']} chains)")
        print(f"file: {info['file']}")
        print(f"options ({len(info['options'])}; use NAME:OPTION):")
        for k, v in info["options"].items():
            print(f"  {k}: {v}")
        print(f"assumptions ({len(info['assumptions'])}):")
        for k, v in info["assumptions"].items():
            print(f"  {k}: {v}")
        print(f"components ({len(info['components'])}):")
        for k, v in info["components"].items():
            print(f"  {k}: {v}")
        return 0
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
    p = sub.add_parser("machines", help="list the bundled machines, one line each (or show one machine)")
    p.add_argument("name", nargs="?", default=None,
                   help="show this machine's options, assumptions and components (bundled name or file)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_machines)
