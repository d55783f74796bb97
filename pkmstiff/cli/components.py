"""``pkmstiff components``: the component models, or the declared parameters of one."""

from __future__ import annotations

import argparse
import json

from pkmstiff.errors import ArgumentError


def _cmd_components(args: argparse.Namespace) -> int:
    from components import catalogue  # listed from the models' parameter declarations
    from components.registry import available_models

    if args.model and args.model not in available_models():
        raise ArgumentError(f"unknown component model {args.model!r}; expected one of "
                       f"{', '.join(sorted(available_models()))}")
    if args.json:
        print(json.dumps(catalogue.as_json(args.model), indent=2))
        return 0
    print("\n".join(catalogue.model_listing(args.model) if args.model else catalogue.listing()))
    return 0


def add_commands(sub) -> None:
    p = sub.add_parser("components", help="list the component models (or the parameters of one)")
    p.add_argument("model", nargs="?", help="show the parameters of this model")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_components)
