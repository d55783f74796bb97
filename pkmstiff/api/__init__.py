"""The public API for design studies (the layer above the library; see docs/user-guide/api.md).

    >>> import pkmstiff
    >>> m = pkmstiff.load_machine("hexaglide")                       # a StudyMachine (a Machine with methods)
    >>> p = m.point([0, 0, -1.0, 0, 0, 0], tool_length=0.15)         # SI: m, rad
    >>> s = m.section("yz", at=0.0, step=0.025, quantities=["kx"])   # s.to_xarray(), s.statistics(), s.plot(...)

:class:`StudyMachine` methods: ``point`` (→ :class:`PointResults`, ``to_pandas()``), ``section`` (→
:class:`SectionMap`, ``to_xarray()``), ``workspace`` (→ :class:`Workspace`), ``rotation_map`` (→ :class:`RotationMap`)
and ``with_`` (a variant). A study writes its report with :class:`Report`, :class:`Table`, :class:`Figure` and
:func:`write_report` (:mod:`pkmstiff.report`), and evaluates component models with :class:`ComponentState`.
"""

from components import ComponentState
from pkmstiff.api.machine import StudyMachine, load_machine
from pkmstiff.api.points import PointResults
from pkmstiff.api.results import RotationMap, SectionMap, Workspace


def __getattr__(name: str):
    """The report model and the quantity list, imported on first use (``import pkmstiff.api`` stays light)."""
    if name in ("Report", "Table", "Figure", "write_report"):
        import pkmstiff.report as report

        return getattr(report, name)
    if name in ("ColourScale", "robust_clim"):  # colour limits a study shares between its map panels
        import pkmstiff.plots.section_maps as section_maps

        return getattr(section_maps, name)
    if name == "ALL_CHECKS":
        from pkmstiff.admissibility.checks import ALL_CHECKS

        return ALL_CHECKS
    if name == "available_quantities":
        from pkmstiff.evaluation.quantities import available_quantities

        return available_quantities
    raise AttributeError(f"module 'pkmstiff.api' has no attribute {name!r}")


__all__ = ["ALL_CHECKS", "ColourScale", "ComponentState", "Figure", "PointResults", "Report", "RotationMap", "SectionMap", "StudyMachine", "Table",
           "Workspace", "available_quantities", "load_machine", "robust_clim", "write_report"]
