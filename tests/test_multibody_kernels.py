"""Compiled batch path (pkmstiff.multibody.fast / kernels) against the numpy path it replaces for large chunks:
TCP compliance/stiffness and natural frequencies on sections of the Hexaglide and the Hexapod 6X, a generic SDE
model with point masses, rigid bodies and 6×6 elements, and the non-positive-definite flagging."""

from __future__ import annotations

import numpy as np
import pytest

import pkmstiff.multibody as sde
from pkmstiff.analysis import batch, evaluate_structure
from pkmstiff.machine.loader import load_machine
from pkmstiff.multibody.assembly import stiffness_matrix
from pkmstiff.multibody.fast import compiled_chunk
from pkmstiff.multibody.modal import dynamic_system, modal_chunk
from pkmstiff.multibody.solver import StaticSystem
from pkmstiff.multibody.static import point_transform
from pkmstiff.structure import NOT_POSITIVE_DEFINITE, build_structure


def _section(name: str, n: int = 15) -> np.ndarray:
    """A section grid (n² poses) with small random orientations, reaching beyond the workspace at its edges."""
    u, v = np.meshgrid(np.linspace(0.0, 1.0, n), np.linspace(0.0, 1.0, n))
    x = np.zeros((n * n, 6))
    if name == "hexaglide":  # YZ section
        x[:, 1], x[:, 2] = -0.1 + 0.9 * u.ravel(), -1.2 + 0.7 * v.ravel()
    else:  # XY section
        x[:, 0], x[:, 1], x[:, 2] = -0.8 + 1.6 * u.ravel(), -0.8 + 1.6 * v.ravel(), -1.2
    x[:, 3:] = np.radians(2.0) * np.random.default_rng(3).uniform(-1.0, 1.0, (n * n, 3))
    return x


@pytest.mark.parametrize("name", ["hexaglide", "hexapod_6x"])
def test_compiled_batch_equals_the_numpy_path_on_a_section(name, monkeypatch):
    machine = load_machine(name)
    poses = _section(name)
    monkeypatch.setattr(batch, "use_compiled", lambda model: False)
    ref = evaluate_structure(machine, poses, chunk_size=128)
    monkeypatch.setattr(batch, "use_compiled", lambda model: True)
    res = evaluate_structure(machine, poses, chunk_size=128)
    ok = ref.ok
    assert np.array_equal(res.ok, ok) and ok.sum() > 100  # the section must contain modelled poses
    # same arithmetic in a different order (assembly bit for bit, block elimination by another Cholesky ordering):
    # backward-stable round-off, relative error <= c eps cond(K_c) with K_c the stiffness condensed onto the
    # platform; measured c <= 0.22, so 1e-12 wherever cond(K_c) < 4.5e3 (all but the near-singular poses at the
    # section's edge, where the old path is no more accurate than the new one)
    st_ = build_structure(machine, poses[ok])
    body = "platform"
    model = st_.dynamic_model if st_.massless_spindle else st_.model
    ev = np.linalg.eigvalsh(StaticSystem(model).condensed_stiffness(body))
    rtol = np.maximum(1e-12, np.finfo(float).eps * ev[:, -1] / ev[:, 0])
    rel = np.abs(res.stiffness[ok] - ref.stiffness[ok]) / ref.stiffness[ok]
    assert (rel <= rtol[:, None]).all()
    rel_c = np.abs(res.compliance[ok] - ref.compliance[ok]).max(axis=(1, 2)) / np.abs(ref.compliance[ok]).max(axis=(1, 2))
    assert (rel_c <= rtol).all()
    # the eigenproblem matrix A is assembled by the same formulas in another code (numba vs numpy/BLAS: other
    # summation orders and fused multiply-adds, varying with the library versions), so it agrees to round-off
    # ‖δA‖ ≤ c ε ‖A‖ only, and by Weyl |δλ_i| ≤ c ε λ_max: f_i = √λ_i/2π moves by c ε λ_max/(2 λ_i) relative —
    # large where λ_min is ill-conditioned (f1 < 1 Hz at the section's edge)
    _assert_frequencies_agree(res.frequencies_hz[ok], ref.frequencies_hz[ok], st_.dynamic_model)
    assert np.isnan(res.stiffness[~ok]).all() and np.isnan(res.frequencies_hz[~ok]).all()


def _assert_frequencies_agree(freq: np.ndarray, ref: np.ndarray, model: sde.SDEModel) -> None:
    """Natural frequencies of two implementations within the round-off bound c ε λ_max/(2 λ_i) (see the caller);
    c = 32 for the assembly sums over a few dozen DOFs (measured: ≤ 6.5 on the Hexaglide and the 6X sections)."""
    lam = np.linalg.eigvalsh(dynamic_system(model).a)
    rtol = 32 * np.finfo(float).eps * lam[:, -1:] / (2 * lam[:, :ref.shape[1]])
    assert (np.abs(freq - ref) <= rtol * ref).all()


def _generic_model(n_p: int) -> sde.SDEModel:
    """Frame – rigid body A (6×6 and rank-one elements) – rigid body B (6×6) – two point masses (3×3 and axial)."""
    rng = np.random.default_rng(5)
    m = sde.SDEModel()

    def spd(d, e=1):
        a = rng.standard_normal((n_p, e, d, d))
        return a @ np.swapaxes(a, -1, -2) + d * np.eye(d)

    rot = np.linalg.qr(rng.standard_normal((n_p, 3, 3)))[0]
    m.add_rigid_body("A", 50.0, rng.uniform(-0.2, 0.2, (n_p, 3)), np.diag([2.0, 3.0, 4.0]), rotation=rot)
    m.add_rigid_body("B", rng.uniform(5.0, 9.0, n_p), rng.uniform(-0.2, 0.2, (n_p, 3)), np.diag([0.5, 0.7, 0.9]))
    m.add_point_mass("p1", 3.0, rng.uniform(-1.0, 1.0, (n_p, 3)))
    m.add_point_mass("p2", 2.0, rng.uniform(-1.0, 1.0, (n_p, 3)))
    m.add_sde("F", "frame", "A", rng.uniform(-0.5, 0.5, (n_p, 3)), stiffness=1e7 * spd(6)[:, 0], check_psd=False)
    m.add_sde_set(["s1", "s2", "s3"], "frame", "A", rng.uniform(-1, 1, (n_p, 3, 3)), k=rng.uniform(1e6, 1e7, 3),
                  axis=rng.standard_normal((n_p, 3, 3)))
    m.add_sde("AB", "A", "B", rng.uniform(-0.5, 0.5, (n_p, 3)), stiffness=1e6 * spd(6)[:, 0], check_psd=False)
    m.add_sde_set(["w1", "w2"], ["p1", "p2"], "frame", rng.uniform(-1, 1, (n_p, 2, 3)), stiffness=1e6 * spd(3, 2),
                  check_psd=False)
    m.add_sde_set(["v1", "v2"], ["p1", "p2"], "B", rng.uniform(-1, 1, (n_p, 2, 3)), k=[2e6, 3e6],
                  axis=rng.standard_normal((n_p, 2, 3)))
    return m


@pytest.mark.parametrize("body", ["A", "B"])
def test_compiled_chunk_on_a_generic_model(body):
    """Every element form (6×6, 3×3, rank one; frame, point mass, rigid body on either side) and a kept body that
    is eliminated last or in the middle of the body graph, over more poses than one kernel block."""
    model = _generic_model(300)
    point = np.random.default_rng(9).uniform(-0.3, 0.3, (300, 3))
    transform = point_transform(model, body, point)
    comp, lam = compiled_chunk(model, body, transform, 4)
    ref = StaticSystem(model).body_compliance(body, transform)
    # round-off of two Cholesky orderings of a well-conditioned K (cond ~1e3): 1e-12 relative to the largest entry
    np.testing.assert_allclose(comp, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    # several elements per block are summed in another order here (and numpy's 6×6 products may run in BLAS), so
    # K agrees to round-off only; the lowest eigenvalues are well separated from 0 (λ_max/λ_min < 1e3): 1e-12
    np.testing.assert_allclose(lam, modal_chunk(model, 4, False).eigenvalues, rtol=1e-12)


def test_compiled_chunk_defers_massless_models_and_rejects_too_many_modes():
    st_ = build_structure(load_machine("hexaglide"), _section("hexaglide", 4)[5:7])
    model = st_.model  # with the massless spindle: the eigenproblem needs a static condensation (numpy path)
    comp, lam = compiled_chunk(model, "spindle", point_transform(model, "spindle", None), 6)
    assert lam is None
    ref = StaticSystem(model).body_compliance("spindle")
    # round-off bound eps cond(K) relative to the largest entry (the stiff U coupling is eliminated with
    # cancellation, so the full K's condition number governs here)
    ev = np.linalg.eigvalsh(np.ascontiguousarray(stiffness_matrix(model)))
    tol = np.maximum(1e-12, np.finfo(float).eps * ev[:, -1] / ev[:, 0]) * np.abs(ref).max(axis=(1, 2))
    assert (np.abs(comp - ref).max(axis=(1, 2)) <= tol).all()
    with pytest.raises(sde.SDEInputError, match="n_modes"):
        compiled_chunk(st_.dynamic_model, "platform", point_transform(st_.dynamic_model, "platform", None), 25)


def test_non_positive_definite_pose_is_flagged_by_the_compiled_path(monkeypatch):
    machine = load_machine("hexaglide")
    poses = np.array([[0.0, 0.0, -1.0, 0.0, 0.0, 0.0], [0.05, 0.25, -0.95, 0.03, -0.02, 0.05],
                      [-0.1, 0.35, -0.85, -0.04, 0.05, -0.08]])
    st_ = build_structure(machine, poses)
    st_.stiffness.chain[1] = 0.0  # platform held by five chains only: K singular at pose 1
    broken = st_.without(np.zeros(3, bool))
    with pytest.raises(sde.SingularModelError, match=r"poses \[1\]"):
        compiled_chunk(broken.dynamic_model, "platform", point_transform(broken.dynamic_model, "platform", None), 6)
    for flag in (False, True):
        monkeypatch.setattr(batch, "use_compiled", lambda model, f=flag: f)
        out, comp, freq = batch._evaluate_chunk(broken, None, 6)
        assert out.index.tolist() == [0, 2] and out.status.tolist() == [0, NOT_POSITIVE_DEFINITE, 0]
        if not flag:
            ref_c, ref_f = comp, freq
    np.testing.assert_allclose(comp, ref_c, rtol=0, atol=1e-12 * np.abs(ref_c).max())
    _assert_frequencies_agree(freq, ref_f, broken.without(np.array([False, True, False])).dynamic_model)
