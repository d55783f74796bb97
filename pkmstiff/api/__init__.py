"""The public API for design studies (the layer above the library; see docs/user-guide/api.md).

    >>> import pkmstiff
    >>> m = pkmstiff.load_machine("hexaglide")                       # a StudyMachine (a Machine with methods)
    >>> p = m.point([0, 0, -1.0, 0, 0, 0], tool_length=0.15)         # SI: m, rad
    >>> s = m.section("yz", at=0.0, step=0.025, quantities=["kx"])   # s.to_xarray(), s.statistics(), s.plot(...)

:class:`StudyMachine` methods: ``point`` (→ :class:`PointResults`, ``to_pandas()``), ``section`` (→
:class:`SectionMap`, ``to_xarray()``), ``workspace`` (→ :class:`Workspace`), ``rotation_map`` (→ :class:`RotationMap`)
and ``with_`` (a variant).
"""

from pkmstiff.api.machine import StudyMachine, load_machine
from pkmstiff.api.points import PointResults
from pkmstiff.api.results import RotationMap, SectionMap, Workspace

__all__ = ["PointResults", "RotationMap", "SectionMap", "StudyMachine", "Workspace", "load_machine"]
