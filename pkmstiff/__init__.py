"""pkmstiff — stiffness, vibration and workspace analysis of parallel-kinematic machine tools.

Public API (SI units inside: m, rad, kg, N, N/m):

    >>> import pkmstiff
    >>> m = pkmstiff.load_machine("hexaglide")
    >>> ik = pkmstiff.inverse_kinematics(m, [[0, 0, -1.0, 0, 0, 0]])

Layers (each a subpackage; imports only downward): ``units``/``errors`` → ``io`` → ``machine`` → ``kinematics`` →
``admissibility`` → ``multibody`` → ``structure`` → ``analysis`` → ``evaluation`` → ``workspace`` → ``fe`` →
``calibration``/``mechanisms`` → ``plots`` → ``report`` → ``cli``.
"""

from pkmstiff.errors import InputError, PkmstiffError
from pkmstiff.machine import Machine, MachineFileError, UnknownMachineError, bundled_machines, load_machine

__version__ = "0.1.0"


def __getattr__(name: str):
    # the kinematics entry points without importing the kinematics layer at ``import pkmstiff``
    if name in ("inverse_kinematics", "forward_kinematics"):
        import pkmstiff.kinematics as kin

        return getattr(kin, name)
    raise AttributeError(f"module 'pkmstiff' has no attribute {name!r}")


__all__ = ["InputError", "Machine", "MachineFileError", "PkmstiffError", "UnknownMachineError", "bundled_machines",
           "forward_kinematics", "inverse_kinematics", "load_machine", "__version__"]
