"""The interpreted twin of the compiled kernels and the machine cache give exactly the results of the ordinary paths
(start-up speed, issue 12 item 6)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from pkmstiff.admissibility.pipeline import evaluate_poses
from pkmstiff.kinematics import dispatch
from pkmstiff.machine.loader import _load_uncached, bundled_machines, load_machine


def _poses(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo = [-0.6, -0.6, -1.4, -0.4, -0.4, -0.4]
    hi = [0.6, 0.9, -0.6, 0.4, 0.4, 0.4]
    p = rng.uniform(lo, hi, size=(n, 6))
    p[0] = [0.0, 0.3, -0.9, 0.0, 0.0, 0.0]
    p[1] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]  # degenerate: platform in the drive plane
    p[2] = [0.0, 5.0, -1.0, 0.0, 0.0, 0.0]  # far outside: unreachable chains (NaN joint points)
    return p


def _flat(ev) -> dict[str, np.ndarray]:
    out = {"drive": ev.drive, "strut": ev.strut_length, "kappa": ev.kappa, "ok": ev.admissibility.ok,
           "reasons": ev.admissibility.reasons}
    out.update({f"angle_{k}": v for k, v in ev.angles.items()})
    return out


@pytest.mark.parametrize("name", ["hexaglide", "hexapod_6x", "linapod"])
def test_interpreted_kernels_equal_compiled(name, monkeypatch):
    # same IEEE operations in the same order (no fastmath in the compiled kernels): equal bit for bit, NaN where NaN
    m = load_machine(name)
    p = _poses(60, 3)
    monkeypatch.setenv("PKMSTIFF_JIT", "0")
    a = _flat(evaluate_poses(m, p))
    monkeypatch.setenv("PKMSTIFF_JIT", "1")
    b = _flat(evaluate_poses(m, p))
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def test_dispatch_switches_to_compiled_after_enough_poses(monkeypatch):
    monkeypatch.delenv("PKMSTIFF_JIT", raising=False)
    monkeypatch.setitem(dispatch._state, "poses", 0)
    import sys

    monkeypatch.delitem(sys.modules, "pkmstiff.kinematics.kernels", raising=False)
    assert dispatch.kernels_for(1) is dispatch.pure_kernels()
    assert dispatch.kernels_for(dispatch.COMPILE_AFTER) is dispatch.compiled_kernels()


@pytest.mark.parametrize("name", bundled_machines())
def test_cached_machine_equals_fresh_load(name, tmp_path, monkeypatch):
    monkeypatch.setenv("PKMSTIFF_CACHE_DIR", str(tmp_path))
    first = load_machine(name)  # stores
    assert list(tmp_path.glob(f"machine-{name}-*.pickle"))
    cached = load_machine(name)  # reads
    fresh = _load_uncached(name)
    assert pickle.dumps(cached.chains) == pickle.dumps(fresh.chains) == pickle.dumps(first.chains)
    assert cached.name == fresh.name and cached.kind == fresh.kind
    p = _poses(5, 1)
    np.testing.assert_array_equal(evaluate_poses(cached, p).kappa, evaluate_poses(fresh, p).kappa)


def test_damaged_cache_file_falls_back_to_loading(tmp_path, monkeypatch):
    monkeypatch.setenv("PKMSTIFF_CACHE_DIR", str(tmp_path))
    load_machine("hexaglide")
    (f,) = tmp_path.glob("machine-hexaglide-*.pickle")
    f.write_bytes(b"not a pickle")
    assert load_machine("hexaglide").name == "hexaglide"
    monkeypatch.setenv("PKMSTIFF_CACHE", "0")
    assert load_machine("hexaglide").name == "hexaglide"


@pytest.mark.parametrize("trailing", [(), (3,)])
def test_piecewise_cubic_equals_scipy_bit_for_bit(trailing):
    # same operations in the same order as scipy's PPoly evaluation: values and first derivatives identical,
    # at nodes, inside, outside (extrapolated), at both ends and at NaN
    from components.spline import clamped_cubic, clamped_spline

    rng = np.random.default_rng(7)
    x = np.cumsum(rng.uniform(0.05, 0.3, 9))
    y = rng.uniform(1e7, 9e7, (9,) + trailing)
    ref, fast = clamped_spline(x, y), clamped_cubic(x, y)
    xq = np.concatenate([x, rng.uniform(x[0] - 0.5, x[-1] + 0.5, 2000), [np.nan, x[0] - 1e-15, x[-1] + 1e-15]])
    for nu in (0, 1):
        np.testing.assert_array_equal(fast.evaluate_numpy(xq, nu), ref(xq, nu))  # the path without scipy
        np.testing.assert_array_equal(fast(xq, nu), ref(xq, nu))  # whichever path __call__ takes
    np.testing.assert_array_equal(fast.evaluate_numpy(xq.reshape(-1, 1)), ref(xq.reshape(-1, 1)))
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(fast))(x[3]), ref(x[3]))


@pytest.mark.parametrize("command", ["pose", "point"])
def test_one_pose_commands_do_not_import_heavy_modules(command):
    """The start-up target of ``pkmstiff pose``/``point`` (issue 12 item 6, ≤ 0.6 s) rests on not importing numba,
    scipy's heavy parts, matplotlib or pyvista for one pose; a fresh interpreter shows what the command loaded."""
    import json
    import subprocess
    import sys

    code = ("import sys, io, contextlib\n"
            "from pkmstiff.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            f"    main(['{command}', 'hexaglide', '--pose', '0,300,-900,0,0,0', '--json'])\n"
            "print(__import__('json').dumps(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('numba', 'matplotlib', 'pyvista', 'skfem', 'pint'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**__import__("os").environ, "PKMSTIFF_JIT": ""})
    assert json.loads(out.stdout.strip().splitlines()[-1]) == []
