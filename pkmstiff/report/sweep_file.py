"""Sweep files (TOML) for ``pkmstiff sweep``: base machine, parameters and evaluations -> :class:`Sweep`.

    [sweep]
    machine = "hexaglide"            # bundled name (":option" suffix) or path (relative to this file)
    mode = "grid"                    # or "random" (then: samples = N, seed = S)
    overrides = { "joint_types.iwf_3dof.tilt_min" = "7 deg" }   # applied to every task (optional)

    [[parameters]]
    path = "components.strut_950.k"
    unit = "N/um"                    # optional: unit of numeric values
    values = [200, 344, 500]         # grid (random: sampled uniformly from the list)
    # random: distribution = "uniform" | "loguniform" (low, high), "normal" (mean, std, low?, high?)

    [[evaluations]]
    kind = "section"                 # section | point | workspace (see pkmstiff.evaluation.requests)
    quantities = ["kx"]; plane = "yz"; at_mm = 0; range = "y=-200:800,z=-1100:-500"; step_mm = 25
    statistics = ["mean", "max"]; tool_length_mm = 150; orientation_deg = [0, 0, 0]
    skip_checks = ["platform_collision"]   # optional: admissibility checks left out (pkmstiff quantities lists them)

Errors are :class:`SweepFileError` naming the file, the key, what was expected and what was found.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pkmstiff.errors import SweepFileError  # noqa: F401 (re-exported)
from pkmstiff.evaluation.sweep import Choice, LogUniform, Normal, Parameter, Sweep, SweepError, Uniform
from pkmstiff.io import check_keys, read_toml
from pkmstiff.report.sweep_evaluations import Combined, PointValues, SectionStatistics, WorkspaceVolume
from pkmstiff.units import InputError

__all__ = ["SweepFileError", "load_sweep"]

_SWEEP_KEYS = {"machine", "mode", "samples", "seed", "overrides"}
_PARAM_KEYS = {"path", "unit", "values", "distribution", "low", "high", "mean", "std"}
_EVAL_KEYS = {
    "section": {"kind", "quantities", "plane", "at_mm", "range", "step_mm", "statistics", "tool_length_mm",
                "orientation_deg", "frame", "neglect_spindle", "skip_checks"},
    "point": {"kind", "pose", "quantities", "tool_length_mm", "suffix", "frame", "neglect_spindle", "skip_checks"},
    "workspace": {"kind", "resolution_mm", "box_mm", "requirements", "orientation_deg", "method", "frame",
                  "neglect_spindle", "skip_checks"},
}




def _table(src: str, tab: Any, key: str, allowed: set[str]) -> dict[str, Any]:
    return check_keys(tab, allowed, src, f"{key}.", SweepFileError)


def _parameter(src: str, tab: Any, i: int) -> Parameter:
    key = f"parameters[{i + 1}]"
    tab = _table(src, tab, key, _PARAM_KEYS)
    if "path" not in tab:
        raise SweepFileError(src, f"{key}.path", "a dotted machine-file path (the key is required)", "missing key")
    dist = None
    kind = tab.get("distribution")
    try:
        if kind == "uniform":
            dist = Uniform(float(tab["low"]), float(tab["high"]))
        elif kind == "loguniform":
            dist = LogUniform(float(tab["low"]), float(tab["high"]))
        elif kind == "normal":
            dist = Normal(float(tab["mean"]), float(tab["std"]), float(tab.get("low", float("-inf"))),
                          float(tab.get("high", float("inf"))))
        elif kind == "choice":
            dist = Choice(tuple(tab["values"]))
        elif kind is not None:
            raise SweepFileError(src, f"{key}.distribution", "'uniform', 'loguniform', 'normal' or 'choice'", kind)
        values = tab.get("values", [])
        if not isinstance(values, list):
            raise SweepFileError(src, f"{key}.values", "a list of values", values)
        return Parameter(str(tab["path"]), values=tuple(values), distribution=dist, unit=tab.get("unit"))
    except KeyError as exc:
        raise SweepFileError(src, f"{key}.{exc.args[0]}", f"a number (required for distribution {kind!r})",
                             "missing key") from None
    except (TypeError, ValueError) as exc:
        if isinstance(exc, InputError):
            raise
        raise SweepFileError(src, key, "a valid parameter", str(exc)) from None


def _evaluation(src: str, tab: Any, i: int):
    key = f"evaluations[{i + 1}]"
    if not isinstance(tab, dict) or tab.get("kind") not in _EVAL_KEYS:
        raise SweepFileError(src, f"{key}.kind", f"one of {sorted(_EVAL_KEYS)}",
                             tab.get("kind") if isinstance(tab, dict) else tab)
    kind = tab["kind"]
    kw = {k: (tuple(v) if isinstance(v, list) else v) for k, v in _table(src, tab, key, _EVAL_KEYS[kind]).items()
          if k != "kind"}
    cls = {"section": SectionStatistics, "point": PointValues, "workspace": WorkspaceVolume}[kind]
    try:
        return cls(**kw)
    except TypeError as exc:  # a required argument is missing
        raise SweepFileError(src, key, f"the settings of a {kind} evaluation", str(exc)) from None
    except SweepError as exc:
        raise SweepFileError(src, key, f"valid {kind} settings", str(exc)) from None


def load_sweep(path: str | Path) -> Sweep:
    """Read and validate a sweep file."""
    path = Path(path)
    src = str(path)
    raw = read_toml(path, SweepFileError, "sweep file")
    _table(src, raw, "(top level)", {"sweep", "parameters", "evaluations"})
    sw = _table(src, raw.get("sweep"), "sweep", _SWEEP_KEYS)
    if "machine" not in sw:
        raise SweepFileError(src, "sweep.machine", "a bundled machine name or path (the key is required)",
                             "missing key")
    machine = str(sw["machine"])
    base = machine.split(":", 1)[0]
    if base.endswith(".toml") and not Path(base).is_absolute():
        machine = str(path.parent / machine)
    params = raw.get("parameters")
    if not isinstance(params, list) or not params:
        raise SweepFileError(src, "parameters", "an array of at least one [[parameters]] table", params)
    evals = raw.get("evaluations")
    if not isinstance(evals, list) or not evals:
        raise SweepFileError(src, "evaluations", "an array of at least one [[evaluations]] table", evals)
    evaluation = [_evaluation(src, t, i) for i, t in enumerate(evals)]
    overrides = sw.get("overrides", {})
    if not isinstance(overrides, dict):
        raise SweepFileError(src, "sweep.overrides", "a table of dotted machine-file paths = values", overrides)
    from pkmstiff.report.spec import _flatten

    try:
        return Sweep(machine, tuple(_parameter(src, t, i) for i, t in enumerate(params)),
                     evaluation[0] if len(evaluation) == 1 else Combined(tuple(evaluation)),
                     mode=sw.get("mode", "grid"), n_samples=sw.get("samples", 0), seed=sw.get("seed", 0),
                     base_overrides=_flatten(overrides))
    except SweepError as exc:
        raise SweepFileError(src, "sweep", "a valid sweep", str(exc)) from None
