"""The component catalogue, generated from the model declarations (:class:`~components.params.ModelSpec`).

:func:`markdown` is the catalogue page of the documentation (one section per registered model: description,
parameter table, source equation and, for table models, the provenance of the bundled joint tables);
:func:`listing` and :func:`model_listing` are the ``pkmstiff components`` output, :func:`as_json` its JSON
form. Run ``python -m components.catalogue PATH`` to write the page.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

from components.joint_tables import JointTable, bundled_tables, load_joint_table
from components.params import ModelSpec, Param
from components.registry import model_info, models

_INTRO = """\
Every component model of the library, generated from the parameter declarations next to the model classes
(`components/*.py`, `MODELS`). A machine file selects a model with `model = "..."` in a
`[components.<name>]` table. Quantities are read with units (`pkmstiff.units.parse_quantity`): a bare number
is SI, a string carries its unit (`"25 N/um"`, `"150 mm"`, `"30 deg"`), and `{value = [...], unit = "..."}`
is accepted for arrays. Every model also accepts `assumptions = {param = "one-line reason"}` and
`provenance = "..."`. The command `pkmstiff components [MODEL]` prints the same declarations."""


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def meaning(decl: Param) -> str:
    """Meaning of a parameter followed by what the reader accepts (range, shape, choices)."""
    return f"{decl.meaning}; {decl.accepts}" if decl.accepts else decl.meaning


def _grid(table: JointTable) -> str:
    tilt = np.rad2deg(table.tilt)
    text = f"{tilt.size} tilt ({tilt[0]:g}–{tilt[-1]:g}°)"
    if table.swivel is None:
        return text
    swivel = np.rad2deg(table.swivel)
    return f"{swivel.size} swivel ({swivel[0]:g}–{swivel[-1]:g}°) × {text}"


def bundled_table_provenance(kind: str) -> list[JointTable]:
    """The bundled joint tables of one format (``"tilt"`` or ``"swivel_tilt"``), by name."""
    tables = [load_joint_table(name) for name in bundled_tables()]
    return [t for t in tables if (t.swivel is not None) == (kind == "swivel_tilt")]


def _tables_section(kind: str) -> list[str]:
    tables = bundled_table_provenance(kind)
    if not tables:
        return ["", "No bundled table has this format: give a CSV path or inline data."]
    lines = ["", "Bundled tables (`table = \"<name>\"`):", "",
             "| name | support points | method | convention | source |", "|---|---|---|---|---|"]
    for t in tables:
        source = t.metadata.get("source", "")
        if t.method == "FE":
            source += f"; mesh {t.metadata.get('mesh_size', '?')}; {t.metadata.get('version', '?')}, " \
                      f"{t.metadata.get('date', '?')}"
        lines.append(f"| `{t.name}` | {_grid(t)} | {t.method} | {t.angle_convention} | {_cell(source)} |")
    return lines


def model_section(spec: ModelSpec) -> list[str]:
    """The Markdown section of one model."""
    lines = [f"## `{spec.name}`", "", f"{spec.description}.", ""]
    if spec.equation:
        lines += [f"Source: {spec.equation}.", ""]
    lines += ["| key | unit | default | meaning |", "|---|---|---|---|"]
    lines += [f"| `{d.key}` | {_cell(d.unit)} | {_cell(d.default_doc)} | {_cell(meaning(d))} |"
              for d in spec.parameters]
    if spec.tables:
        lines += _tables_section(spec.tables)
    return lines + [""]


def markdown() -> str:
    """The catalogue page (Markdown) of every registered model, in registration order."""
    specs = models()
    lines = ["# Component catalogue", "", _INTRO, "", "| model | description | source |", "|---|---|---|"]
    lines += [f"| [`{s.name}`](#{s.name}) | {_cell(s.description)} | {_cell(s.equation)} |"
              for s in specs]
    lines.append("")
    for spec in specs:
        lines += model_section(spec)
    return "\n".join(lines).rstrip("\n") + "\n"


def listing() -> list[str]:
    """One line per model: name and description (sorted by name)."""
    specs = sorted(models(), key=lambda s: s.name)
    width = max(len(s.name) for s in specs)
    return [f"{s.name:<{width}}  {s.description}" for s in specs]


def model_listing(name: str) -> list[str]:
    """The description and the parameter declarations of one model, one line each."""
    spec = model_info(name)
    width = max([len(d.key) for d in spec.parameters] + [20])
    head = f"{spec.name}: {spec.description}" + (f" ({spec.equation})" if spec.equation else "")
    return [head] + [f"  {d.key:<{width}} [{d.unit}] default {d.default_doc}: {meaning(d)}" for d in spec.parameters]


def as_json(name: str | None = None) -> Any:
    """JSON-ready form: ``{model: description}``, or the full declaration of one model."""
    if name is None:
        return {s.name: s.description for s in sorted(models(), key=lambda s: s.name)}
    spec = model_info(name)
    return {"name": spec.name, "description": spec.description, "equation": spec.equation,
            "parameters": [{"key": d.key, "unit": d.unit, "default": d.default_doc, "meaning": d.meaning,
                            "accepts": d.accepts} for d in spec.parameters]}


def main(argv: list[str] | None = None) -> int:
    """``python -m components.catalogue [PATH]``: write the page to PATH (default: standard output)."""
    args = sys.argv[1:] if argv is None else argv
    text = markdown()
    if args:
        Path(args[0]).parent.mkdir(parents=True, exist_ok=True)
        Path(args[0]).write_text(text, encoding="utf-8")
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
