"""Interpreted or compiled kernels: which implementation of :mod:`pkmstiff.kinematics.kernels` to run.

Importing numba and loading the compiled kernels from its cache costs ~0.9 s per process, the interpreted kernels
~1.5 ms per pose. A process therefore runs the kernels' own source interpreted (a twin module executed from the same
file with ``_jit`` the identity, so there is one implementation) until it has passed ``COMPILE_AFTER`` poses through
kernels in total (or one call brings that many), and the numba-compiled kernels from then on. ``pkmstiff pose``/
``point`` for one pose never import numba; a batch or a long-running session pays the compile cost once.
``PKMSTIFF_JIT=1`` forces the compiled kernels, ``PKMSTIFF_JIT=0`` the interpreted ones. Both give the same results
(tests/test_kernel_dispatch.py: identical outputs on random and degenerate inputs).
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path
from types import ModuleType

#: pose evaluations through the kernels after which a process switches to the compiled kernels
COMPILE_AFTER = 200

_state = {"poses": 0}
_pure: ModuleType | None = None


def pure_kernels() -> ModuleType:
    """The kernels' source executed without numba (module ``pkmstiff.kinematics._kernels_py``)."""
    global _pure
    if _pure is None:
        name = "pkmstiff.kinematics._kernels_py"
        spec = importlib.util.spec_from_file_location(name, Path(__file__).with_name("kernels.py"))
        assert spec is not None and spec.loader is not None
        mod = importlib.util.module_from_spec(spec)
        mod._PURE_PYTHON = True  # type: ignore[attr-defined]
        spec.loader.exec_module(mod)
        sys.modules[name] = mod
        _pure = mod
    return _pure


def compiled_kernels() -> ModuleType:
    import pkmstiff.kinematics.kernels as kernels

    return kernels


def kernels_for(n_poses: int) -> ModuleType:
    """The kernel module to use for a call over ``n_poses`` poses (see the module docstring)."""
    mode = os.environ.get("PKMSTIFF_JIT", "")
    if mode == "1":
        return compiled_kernels()
    if mode == "0":
        return pure_kernels()
    if "pkmstiff.kinematics.kernels" in sys.modules:
        return sys.modules["pkmstiff.kinematics.kernels"]
    _state["poses"] += int(n_poses)
    if _state["poses"] >= COMPILE_AFTER:
        return compiled_kernels()
    return pure_kernels()


def run(name: str, n_poses: int, *args):
    """Call kernel ``name`` of :func:`kernels_for` ``(n_poses)``; the interpreted kernels run under numpy's "ignore"
    error state, as the compiled ones do (``error_model="numpy"``: x/0 gives inf/NaN silently)."""
    mod = kernels_for(n_poses)
    if getattr(mod, "_PURE_PYTHON", False):
        import numpy as np

        with np.errstate(all="ignore"):
            return getattr(mod, name)(*args)
    return getattr(mod, name)(*args)
