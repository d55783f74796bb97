"""pkmstiff — stiffness, vibration and workspace analysis of parallel-kinematic machine tools.

Public API (SI units inside: m, rad, kg, N, N/m):

    >>> import pkmstiff
    >>> m = pkmstiff.load_machine("hexaglide")
    >>> ik = pkmstiff.inverse_kinematics(m, [[0, 0, -1.0, 0, 0, 0]])
    >>> s = m.section("yz", at=0.0, step=0.025, quantities=["kx"])   # s.to_xarray(), s.statistics()

Layers (each a subpackage; imports only downward): ``units``/``errors`` → ``io`` → ``machine`` → ``kinematics`` →
``admissibility`` → ``multibody`` → ``structure`` → ``analysis`` → ``evaluation`` → ``workspace`` → ``fe`` →
``calibration``/``mechanisms`` → ``plots`` → ``report`` → ``api`` (the design-study API: ``load_machine`` returns a
:class:`~pkmstiff.api.StudyMachine`) → ``optimise`` (``pkmstiff.optimise(design_file, out)``) → ``cli``.
"""

__version__ = "0.1.0"

#: the facade: name -> layer module that defines it (imported on first use, so ``import pkmstiff.errors`` stays light)
_FACADE = {
    "InputError": "pkmstiff.errors", "PkmstiffError": "pkmstiff.errors",
    "Machine": "pkmstiff.machine", "MachineFileError": "pkmstiff.machine", "UnknownMachineError": "pkmstiff.machine",
    "bundled_machines": "pkmstiff.machine",
    "load_machine": "pkmstiff.api", "StudyMachine": "pkmstiff.api", "PointResults": "pkmstiff.api",
    "SectionMap": "pkmstiff.api", "Workspace": "pkmstiff.api", "RotationMap": "pkmstiff.api",
    "Report": "pkmstiff.api", "Table": "pkmstiff.api", "Figure": "pkmstiff.api", "write_report": "pkmstiff.api",
    "ComponentState": "pkmstiff.api", "available_quantities": "pkmstiff.api", "ALL_CHECKS": "pkmstiff.api",
    "ColourScale": "pkmstiff.api", "robust_clim": "pkmstiff.api",
    "load_design": "pkmstiff.optimise",
    "inverse_kinematics": "pkmstiff.kinematics", "forward_kinematics": "pkmstiff.kinematics",
}


def __getattr__(name: str):
    if name == "optimise":  # the subpackage, callable: pkmstiff.optimise(design_file, out=...)
        import importlib

        return importlib.import_module("pkmstiff.optimise")
    if name in _FACADE:
        import importlib

        return getattr(importlib.import_module(_FACADE[name]), name)
    raise AttributeError(f"module 'pkmstiff' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(list(globals()) + list(_FACADE) + ["optimise"])


__all__ = ["ALL_CHECKS", "ColourScale", "ComponentState", "Figure", "InputError", "Machine", "MachineFileError", "PkmstiffError", "PointResults",
           "Report", "RotationMap", "SectionMap", "StudyMachine", "Table", "UnknownMachineError", "Workspace",
           "available_quantities", "bundled_machines", "forward_kinematics", "inverse_kinematics", "load_design", "load_machine", "optimise", "robust_clim",
           "write_report", "__version__"]
