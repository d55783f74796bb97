"""Reading FE parameter files (TOML) into SI values with unit checks and clear errors.

Quantities may carry units (``"60 mm"``, ``"210 GPa"``, ``"5 kN"``); bare numbers are SI. Every error is
an :class:`~pkmstiff.units.InputError` naming the file, the key, the expectation and the finding.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

from pkmstiff.errors import ArgumentError, InputError
from pkmstiff.fe.materials import CubicCylindrical, Isotropic, Material
from pkmstiff.io import check_keys
from pkmstiff.units import parse_quantity

# schema: section -> key -> unit ("m", "Pa", "N", ... positive; "m0" non-negative; "m~" any sign; "str" text,
# "int" count, "-" dimensionless)
Schema = Mapping[str, Mapping[str, str]]


#: the parameter files shipped with the package (pkmstiff/fe/params/*.toml)
PARAMS_DIR = Path(__file__).resolve().with_name("params")


def bundled_parameter_files() -> list[str]:
    """Names of the shipped FE parameter files (``iwf_3dof_improved``, ``hexaglide_platform``, ...)."""
    return sorted(p.stem for p in PARAMS_DIR.glob("*.toml"))


def resolve_parameter_file(path: str | Path) -> Path:
    """An existing file as given; otherwise a shipped parameter file of that name, so that the documented examples
    work from any directory: ``iwf_3dof_improved``, ``iwf_3dof_improved.toml`` and the path in the clone,
    ``pkmstiff/fe/params/iwf_3dof_improved.toml``, all name the shipped file."""
    p = Path(path)
    if p.exists():
        return p
    name = p.name if p.suffix == ".toml" else f"{p.name}.toml"
    shipped = PARAMS_DIR / name
    if shipped.is_file() and (len(p.parts) == 1 or p.parts[-3:-1] == ("fe", "params")):
        return shipped
    return p


def read_section(raw: Mapping[str, Any], section: str, spec: Mapping[str, str], source: str,
                 optional: frozenset[str] = frozenset()) -> dict[str, Any]:
    """Read ``[section]`` with the keys of ``spec`` (unit per key); unknown keys are rejected."""
    tab = raw.get(section)
    if not isinstance(tab, dict):
        raise InputError(source, section, f"a [{section}] table with keys {', '.join(spec)}", tab)
    check_keys(tab, spec, source, f"{section}.")
    out: dict[str, Any] = {}
    for key, unit in spec.items():
        full = f"{section}.{key}"
        if key not in tab:
            if key in optional:
                continue
            raise InputError(source, full, f"a value ({unit})", "missing")
        v = tab[key]
        if unit == "str":
            if not isinstance(v, str):
                raise InputError(source, full, "a string", v)
            out[key] = v
        elif unit == "int":
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise InputError(source, full, "a positive integer", v)
            out[key] = v
        elif unit == "-":
            out[key] = parse_quantity(v, "dimensionless", source=source, key=full)
        elif unit.endswith("~"):  # quantity of any sign, e.g. a coordinate "m~"
            out[key] = parse_quantity(v, unit[:-1], source=source, key=full)
        elif unit.endswith("0"):  # non-negative quantity, e.g. "m0"
            out[key] = parse_quantity(v, unit[:-1], source=source, key=full, min_value=0.0)
        else:
            out[key] = parse_quantity(v, unit, source=source, key=full, positive=True)
    return out


def read_materials(raw: Mapping[str, Any], source: str) -> dict[str, Material]:
    """``[materials.NAME]`` tables: isotropic (E, nu[, density]) or ``law = "cubic_cylindrical"`` (E, G, nu)."""
    tab = raw.get("materials")
    if not isinstance(tab, dict) or not tab:
        raise InputError(source, "materials", "at least one [materials.NAME] table", tab)
    out: dict[str, Material] = {}
    for name, m in tab.items():
        key = f"materials.{name}"
        if not isinstance(m, dict):
            raise InputError(source, key, "a table", m)
        law = m.get("law", "isotropic")
        try:
            if law == "isotropic":
                v = read_section({"m": m}, "m", {"law": "str", "E": "Pa", "nu": "-", "density": "kg/m^3",
                                                 "note": "str"}, source, optional=frozenset({"law", "density", "note"}))
                out[name] = Isotropic(name, v["E"], v["nu"], v.get("density", 0.0))
            elif law == "cubic_cylindrical":
                v = read_section({"m": m}, "m", {"law": "str", "E": "Pa", "G": "Pa", "nu": "-", "density": "kg/m^3",
                                                 "note": "str"}, source, optional=frozenset({"density", "note"}))
                out[name] = CubicCylindrical(name, v["E"], v["G"], v["nu"], density=v.get("density", 0.0))
            else:
                raise InputError(source, f"{key}.law", "'isotropic' or 'cubic_cylindrical'", law)
        except InputError as exc:
            raise InputError(source, exc.key.replace("m.", f"{key}.", 1), exc.expected, exc.found) from None
        except ArgumentError as exc:
            raise InputError(source, key, "valid material constants", str(exc)) from None
    return out


def material(materials: Mapping[str, Material], name: str, source: str, key: str) -> Material:
    """Look up a named material (error names the key that referenced it)."""
    if name not in materials:
        raise InputError(source, key, f"one of the materials {', '.join(materials)}", name)
    return materials[name]


def read_assumptions(raw: Mapping[str, Any], source: str) -> dict[str, str]:
    """``[assumptions]``: key -> one-line reason."""
    tab = raw.get("assumptions", {})
    if not isinstance(tab, dict) or not all(isinstance(v, str) for v in tab.values()):
        raise InputError(source, "assumptions", "a table parameter = one-line reason (strings)", tab)
    return dict(tab)
