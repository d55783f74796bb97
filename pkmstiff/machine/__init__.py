"""Machine layer: the machine model, machine files (loading, validation, variants) and component roles."""

from pkmstiff.machine.loader import (
                                     UnknownMachineError,
                                     bundled_machine_dir,
                                     bundled_machines,
                                     load_machine,
                                     raw_machine,
                                     resolve_machine_path,
                                     split_machine_spec,
)
from pkmstiff.machine.model import Chains, Guide, Hull, JointType, Limits, Machine, Tool

__all__ = ["Chains", "Guide", "Hull", "JointType", "Limits", "Machine", "Tool",
           "UnknownMachineError", "bundled_machine_dir", "bundled_machines", "load_machine", "raw_machine",
           "resolve_machine_path", "split_machine_spec"]
