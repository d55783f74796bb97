"""pkmstiff — stiffness, vibration and workspace analysis of parallel-kinematic machine tools.

Public API (SI units inside: m, rad, kg, N, N/m):

    >>> import pkmstiff
    >>> m = pkmstiff.load_machine("hexaglide")
    >>> ik = pkmstiff.inverse_kinematics(m, [[0, 0, -1.0, 0, 0, 0]])
"""

from .machine_file import MachineFileError, UnknownMachineError, bundled_machines, load_machine
from .model import Machine
from .units import InputError

__version__ = "0.1.0"

__all__ = ["InputError", "Machine", "MachineFileError", "UnknownMachineError", "bundled_machines", "load_machine",
           "__version__"]
