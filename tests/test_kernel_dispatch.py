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


def _same_state(a, b) -> bool:
    """Same object graph: same classes, values (arrays bit for bit) and sharing of containers and objects (the
    cache's own description is a canonical form of it; equal strings need not be one object)."""
    from pkmstiff.machine.cache import encode

    (ta, aa), (tb, ab) = encode(a), encode(b)
    return ta == tb and aa.keys() == ab.keys() and all(
        aa[k].dtype == ab[k].dtype and np.array_equal(aa[k], ab[k], equal_nan=True) for k in aa)


@pytest.mark.parametrize("name", bundled_machines())
def test_cached_machine_equals_fresh_load(name, tmp_path, monkeypatch):
    monkeypatch.setenv("PKMSTIFF_CACHE_DIR", str(tmp_path))
    first = load_machine(name)  # stores
    assert list(tmp_path.glob(f"machine-{name}-*.npz"))
    cached = load_machine(name)  # reads
    fresh = _load_uncached(name)
    assert _same_state(cached.chains, fresh.chains) and _same_state(first.chains, fresh.chains)
    assert cached.name == fresh.name and cached.kind == fresh.kind
    p = _poses(5, 1)
    np.testing.assert_array_equal(evaluate_poses(cached, p).kappa, evaluate_poses(fresh, p).kappa)
    # the components too (joint tables, splines, drives): the structure model's stiffness bit for bit
    from pkmstiff.analysis import evaluate_structure
    from pkmstiff.errors import StructureModelError

    ok = evaluate_poses(fresh, p).ok
    try:
        k_fresh = evaluate_structure(fresh, p[ok], n_modes=0).stiffness
    except StructureModelError:  # a machine without stiffness data
        return
    np.testing.assert_array_equal(evaluate_structure(cached, p[ok], n_modes=0).stiffness, k_fresh)


def test_damaged_cache_file_falls_back_to_loading(tmp_path, monkeypatch):
    monkeypatch.setenv("PKMSTIFF_CACHE_DIR", str(tmp_path))
    load_machine("hexaglide")
    (f,) = tmp_path.glob("machine-hexaglide-*.npz")
    f.write_bytes(b"not an archive")
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


# ------------------------------------------------------------------------------------------------ cache safety


def _cache_file(tmp_path, name="hexaglide"):
    (f,) = tmp_path.glob(f"machine-{name}-*.npz")
    return f


def test_planted_pickle_is_never_executed(tmp_path, monkeypatch):
    """A pickle planted under the cache's name (old format) or inside the archive never runs: the run succeeds."""
    import os
    import pickle as pk

    monkeypatch.setenv("PKMSTIFF_CACHE_DIR", str(tmp_path))
    load_machine("hexaglide")
    f = _cache_file(tmp_path)
    marker = tmp_path / "pwned"

    class Evil:
        def __reduce__(self):
            return (os.system, (f"touch {marker}",))

    f.with_suffix(".pickle").write_bytes(pk.dumps(Evil()))  # the old cache name
    f.write_bytes(pk.dumps(Evil()))  # a pickle where the archive belongs
    assert load_machine("hexaglide").name == "hexaglide"
    np.savez(f, __json__=np.frombuffer(pk.dumps(Evil()), np.uint8))  # a pickle as the archive's description
    assert load_machine("hexaglide").name == "hexaglide"
    import io

    buf = io.BytesIO()
    np.save(buf, np.array([Evil()], dtype=object), allow_pickle=True)  # an object array inside the archive
    with open(f, "wb") as fh:
        np.savez(fh, __json__=np.frombuffer(b'{"array": "a0"}', np.uint8), a0=np.array([Evil()], dtype=object))
    assert load_machine("hexaglide").name == "hexaglide"
    assert not marker.exists()


def test_cache_file_naming_a_foreign_class_is_refused(tmp_path, monkeypatch):
    from pkmstiff.machine import cache

    for name in ("os:system", "subprocess:Popen", "builtins:eval", "pkmstiff.io.atomic:atomic_write_text",
                 "pkmstiff:load_machine"):
        with pytest.raises(cache.Unsupported):
            cache.decode('{"object": "%s", "id": 0, "state": null}' % name, {})
    with pytest.raises(cache.Unsupported):
        cache.encode(lambda: 0)
    monkeypatch.setenv("PKMSTIFF_CACHE_DIR", str(tmp_path))
    load_machine("hexaglide")
    f = _cache_file(tmp_path)
    np.savez(f, __json__=np.frombuffer(b'{"object": "os:system", "id": 0, "state": null}', np.uint8))
    assert load_machine("hexaglide").name == "hexaglide"  # fallback to the normal load


def test_cache_shared_with_others_is_not_read(tmp_path, monkeypatch):
    """A cache file (or directory) that group or others may write is ignored, and the load still succeeds."""
    from pkmstiff.machine import cache

    monkeypatch.setenv("PKMSTIFF_CACHE_DIR", str(tmp_path))
    load_machine("hexaglide")
    f = _cache_file(tmp_path)
    assert oct(f.stat().st_mode & 0o777) == oct(0o600)
    calls = []
    monkeypatch.setattr(cache, "decode", lambda *a: calls.append(a))
    f.chmod(0o666)
    assert load_machine("hexaglide").name == "hexaglide" and not calls
    tmp_path.chmod(0o777)
    try:
        assert load_machine("hexaglide").name == "hexaglide" and not calls
    finally:
        tmp_path.chmod(0o700)


def test_cache_round_trip_keeps_shared_objects_shared(tmp_path):
    from pkmstiff.machine import cache

    m = _load_uncached("hexaglide")
    text, arrays = cache.encode(m)
    back = cache.decode(text, arrays)
    assert _same_state(back, m)
    for name, (raw, _) in back.built_components.items():
        assert back.components[name] is raw
