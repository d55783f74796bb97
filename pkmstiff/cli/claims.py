"""Facts the README and the docs state, computed from the code and data so that they cannot drift (issue 12, item 7).

``collect_claims()`` returns the countable facts (bundled machines with their assumption and option counts, the
quantities with every family, the CLI commands, the demo's output files, the JSON schemas, the evaluation counts of
the rotation map quoted in docs/user-guide/workspace.md); ``render_markdown()``
renders the README's generated block. ``tests/test_claims.py`` compares the facts with ``docs/claims.json`` and the
README's block (between ``<!-- claims:start -->`` and ``<!-- claims:end -->``) with ``render_markdown()``; after a
deliberate change run ``python -m pkmstiff.cli.claims --write`` and commit both. (It lives in the command-line
package because it counts the commands.)
"""

from __future__ import annotations

import argparse
import json
from functools import lru_cache
from pathlib import Path
from typing import Any

from pkmstiff.io.atomic import atomic_write_text

ROOT = Path(__file__).resolve().parents[2]
CLAIMS_FILE = ROOT / "docs" / "claims.json"
START, END = "<!-- claims:start -->", "<!-- claims:end -->"


def collect_claims() -> dict[str, Any]:
    """The README's countable facts, recomputed."""
    from pkmstiff.cli import build_parser
    from pkmstiff.evaluation.quantities import _FAMILIES, _REGISTRY
    from pkmstiff.machine.loader import bundled_machines, load_machine, raw_machine
    from pkmstiff.report.demo import output_files

    machines = {}
    for name in bundled_machines():
        m = load_machine(name)
        raw = raw_machine(name)[0]
        machines[name] = {"title": m.title, "type": m.kind, "chains": m.n_chains,
                          "assumptions": len(m.assumptions), "options": sorted(raw.get("options") or {})}
    sub = next(a for a in build_parser()._actions if a.__class__.__name__ == "_SubParsersAction")
    schemas = sorted(p.name for p in (ROOT / "pkmstiff" / "schemas").glob("*.schema.json"))
    return {
        "machines": machines,
        "quantities": sorted(_REGISTRY),
        "quantity_families": [pat.pattern.removesuffix("\\Z") for pat, _, _ in _FAMILIES],
        "quantity_family_examples": [ex for _, _, ex in _FAMILIES],
        "commands": sorted(sub.choices),
        "demo_files": sorted(output_files()),
        "demo_figure_and_data_files": len(output_files()) - 2,
        "json_schemas": schemas,
        "rotation_map_yz": dict(rotation_map_yz_evaluations()),
    }


#: the rotation-map run docs/user-guide/workspace.md quotes (Hexaglide Y-Z plane, 25 mm raster, 1 deg, six directions)
ROTATION_MAP_YZ = ["rotation-map", "hexaglide", "--plane", "yz", "--at", "0", "--range",
                   "y=-200:1100,z=-1250:-400", "--step", "25", "--increment", "1", "--json"]


@lru_cache(maxsize=1)
def rotation_map_yz_evaluations() -> dict[str, int]:
    """Evaluations of the documented rotation-map run (predictor-corrector) and of the plain incremental search,
    summed over the six directions (deterministic counts; ~3 s)."""
    import contextlib
    import io

    from pkmstiff.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        status = main(ROTATION_MAP_YZ)
    if status != 0:
        raise RuntimeError(f"pkmstiff {' '.join(ROTATION_MAP_YZ)} exited with {status}")
    ev = json.loads(buf.getvalue())["evaluations"]
    used = sum(int(d["evaluations"]) for d in ev.values())
    plain = sum(int(d["plain_sequential"]) for d in ev.values())
    return {"evaluations": used, "plain_sequential": plain, "saved_percent": round(100 * (plain - used) / plain)}


def rotation_map_sentence(c: dict[str, Any]) -> str:
    """The sentence of docs/user-guide/workspace.md that quotes the counts."""
    r = c["rotation_map_yz"]
    return (f"it needs {r['evaluations']:,} evaluations instead of {r['plain_sequential']:,} "
            f"(−{r['saved_percent']} %;")


def render_markdown(claims: dict[str, Any] | None = None) -> str:
    """The README block: machines table with assumption counts, commands, quantity families, demo outputs."""
    c = collect_claims() if claims is None else claims
    lines = [START, "", "| machine | type | chains | assumptions | options |", "|---|---|---|---|---|"]
    for name, m in c["machines"].items():
        lines.append(f"| `{name}` | {m['type']} | {m['chains']} | {m['assumptions']} | "
                     f"{', '.join(f'`{o}`' for o in m['options']) or '—'} |")
    lines += ["", f"Commands ({len(c['commands'])}): " + ", ".join(f"`{x}`" for x in c["commands"]) + ".", "",
              f"Quantities ({len(c['quantities'])} names and {len(c['quantity_families'])} indexed families): "
              + ", ".join(f"`{q}`" for q in c["quantities"]) + "; families "
              + ", ".join(f"`{p}`" for p in c["quantity_families"]) + ".", "",
              f"`pkmstiff demo` writes summary.md, summary.html and {c['demo_figure_and_data_files']} figure/data "
              "files: " + ", ".join(f"`{f}`" for f in c["demo_files"] if not f.startswith("summary")) + ".",
              "", END]
    return "\n".join(lines)


def readme_block(text: str) -> str | None:
    """The generated block of a README text (None if it has none)."""
    if START not in text or END not in text:
        return None
    return text[text.index(START): text.index(END) + len(END)]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m pkmstiff.cli.claims", description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="rewrite docs/claims.json (after a deliberate change)")
    args = ap.parse_args(argv)
    claims = collect_claims()
    if args.write:
        atomic_write_text(CLAIMS_FILE, json.dumps(claims, indent=2, ensure_ascii=False) + "\n")
        print(f"wrote {CLAIMS_FILE}")
    print(render_markdown(claims))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
