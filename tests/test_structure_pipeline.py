"""One pose pipeline (issue 21 item 1): the structure model takes the pose evaluation, a section chunk builds one
structure model for all its structure quantities, and the unchunked analyses work part by part (issue 22 item 14)."""

from __future__ import annotations

import numpy as np
import pytest

import pkmstiff.structure.model as structure_model
import pkmstiff.structure.options as structure_options
from pkmstiff.admissibility import pipeline
from pkmstiff.admissibility.pipeline import evaluate_poses
from pkmstiff.analysis import (
    evaluate_structure,
    gravity_deflection,
    modal_analysis,
    natural_frequencies,
    structure_deflection,
    tcp_compliance,
    tcp_stiffness_matrix,
    weak_points,
)
from pkmstiff.evaluation.sections import axis_plane, evaluate_section, section_poses
from pkmstiff.machine.frames import neglect_spindle
from pkmstiff.structure import build, build_structure, iter_structures

NAMES = ["kx", "share_drive_joint_x", "deflection_gravity"]
PLANE = axis_plane("xy", -0.9, (-0.2, 0.2), (0.25, 0.55), 0.02)  # 21 x 16 points, nearly all admissible
CHUNK = 110  # section chunk: four chunks with admissible poses


def _spy(monkeypatch, module, name):
    calls = []
    original = getattr(module, name)

    def spy(*args, **kw):
        calls.append(args)
        return original(*args, **kw)

    monkeypatch.setattr(module, name, spy)
    return calls


def test_section_builds_one_structure_model_per_chunk(hexaglide, monkeypatch):
    """k_x, share_drive_joint_x and deflection_gravity of a section: one structure model and one inverse kinematics
    per chunk (before: three structure models and four inverse kinematics), and the numbers of the separate
    computations they replace, bit for bit: the same per-pose arithmetic on the same pose sets (the structure model
    of the chunk is the model each of them built for itself)."""
    built = _spy(monkeypatch, build, "_structure_from_evaluation")
    evaluated = _spy(monkeypatch, build, "structure_evaluation")
    iks = _spy(monkeypatch, pipeline, "inverse_kinematics")  # general path
    fast = _spy(monkeypatch, pipeline._fast, "evaluate_small")  # small chunks: the fused kernel (IK included)
    res = evaluate_section(hexaglide, PLANE, NAMES, tool_length=0.1, chunk_size=CHUNK)
    poses = section_poses(PLANE)
    chunks = [poses[s:s + CHUNK] for s in range(0, len(poses), CHUNK)]
    assert len(iks) + len(fast) == len(chunks)  # one inverse kinematics per chunk
    monkeypatch.undo()
    n_with_ok = sum(bool(evaluate_poses(hexaglide, c).ok.any()) for c in chunks)
    assert n_with_ok >= 3 and len(built) == n_with_ok and not evaluated

    ok = res.ok.ravel()
    got = {n: res.values[n].ravel()[ok] for n in NAMES}
    start = 0
    for c in chunks:
        ev = evaluate_poses(hexaglide, c)
        x = c[ev.ok]
        m = int(ev.ok.sum())
        if not m:
            continue
        kx = evaluate_structure(hexaglide, x, tool_length=0.1).stiffness[:, 0]
        wp = weak_points(build_structure(hexaglide, x), "x", tool_length=0.1)
        share = wp.component_shares[:, wp.component_labels.index("drive_joint")]
        defl = np.linalg.norm(gravity_deflection(hexaglide, x, tool_length=0.1)[:, :3], axis=1)
        for name, old in zip(NAMES, (kx, share, defl)):
            np.testing.assert_array_equal(got[name][start:start + m], old, err_msg=name)
        start += m
    assert start == ok.sum()


def test_neglect_spindle_reaches_every_quantity(hexaglide):
    """K_U left out is the machine's typed field, the one source: share_* honours it as k_x does, and the section
    states it."""
    names = ["kx", "share_platform_spindle_x"]
    plane = axis_plane("xy", -0.9, (-0.1, 0.1), (0.2, 0.4), 0.05)
    by_machine = evaluate_section(neglect_spindle(hexaglide), plane, names, tool_length=0.0)
    kept = evaluate_section(hexaglide, plane, names, tool_length=0.0)
    assert np.all(by_machine.values["kx"][by_machine.ok] > kept.values["kx"][by_machine.ok])  # K_U rigid: stiffer
    ok = by_machine.ok
    assert ok.any() and np.all(by_machine.values["share_platform_spindle_x"][ok] == 0.0)
    assert np.all(kept.values["share_platform_spindle_x"][ok] > 0.0)  # K_U kept: it takes a share
    assert by_machine.settings["neglect_spindle"] and "neglect_spindle" not in kept.settings


def test_build_structure_takes_the_evaluation(hexaglide, monkeypatch):
    """From a PoseEvaluation nothing kinematic is computed again; from poses the evaluation runs once."""
    rng = np.random.default_rng(3)
    x = rng.uniform([-0.2, 0.0, -1.0, -0.05, -0.05, -0.05], [0.2, 0.4, -0.85, 0.05, 0.05, 0.05], (40, 6))
    x[0] = [0.0, 5.0, -1.0, 0, 0, 0]  # unreachable
    ev = evaluate_poses(hexaglide, x)
    iks = _spy(monkeypatch, pipeline, "inverse_kinematics")
    fast = _spy(monkeypatch, pipeline._fast, "evaluate_small")
    a = build_structure(hexaglide, ev)
    assert not iks and not fast
    monkeypatch.undo()
    b = build_structure(hexaglide, x)
    np.testing.assert_array_equal(a.reasons, b.reasons)
    assert a.reasons[0] and not a.ok[0] and a.ok[1:].any()
    for f in ("index", "w", "R", "p", "q", "u"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f), err_msg=f)
    np.testing.assert_array_equal(tcp_compliance(a, 0.1), tcp_compliance(b, 0.1))


@pytest.fixture
def small_chunk(monkeypatch):
    """Structures and analyses split into parts of 7 poses; records the largest SDE model assembled."""
    sizes = []
    original = structure_model.sde_model

    def spy(layout, w, *args, **kw):
        sizes.append(len(w))
        return original(layout, w, *args, **kw)

    monkeypatch.setattr(structure_model, "sde_model", spy)
    monkeypatch.setattr(structure_options, "DEFAULT_CHUNK", 7)
    return sizes


def test_unchunked_analyses_work_part_by_part(hexaglide, small_chunk):
    """build_structure, weak_points, modal_analysis and the static analyses on N > chunk poses: every SDE model
    holds at most one chunk of poses (bounded memory), and the results equal the per-chunk results joined, bit
    for bit (each pose's arithmetic does not depend on its neighbours in a chunk)."""
    rng = np.random.default_rng(5)
    x = rng.uniform([-0.2, 0.0, -1.0, -0.05, -0.05, -0.05], [0.2, 0.4, -0.85, 0.05, 0.05, 0.05], (30, 6))
    x[9] = [0.0, 5.0, -1.0, 0, 0, 0]  # an unmodelled pose inside a part
    x[14:21] = [0.0, 5.0, -1.0, 0, 0, 0]  # and a whole part without modelled poses
    st = build_structure(hexaglide, x)
    assert st.n_poses == 30 and len(st.parts()) == 5 and not st.ok[9] and not st.ok[14:21].any()
    wp = weak_points(st, "x", 0.1)
    ma = modal_analysis(st, 4)
    analyses = {
        "weak": lambda s: weak_points(s, "x", 0.1).component_shares,
        "weak_el": lambda s: weak_points(s, "x", 0.1).element_shares,
        "modal_f": lambda s: modal_analysis(s, 4).frequencies_hz,
        "modal_shapes": lambda s: modal_analysis(s, 4).shapes,
        "modal_dominant": lambda s: modal_analysis(s, 4).dominant,
        "freq": lambda s: natural_frequencies(s, 4),
        "comp": lambda s: tcp_compliance(s, 0.1),
        "stiff": lambda s: tcp_stiffness_matrix(s, 0.1),
        "defl": lambda s: structure_deflection(s, 0.1),
    }
    whole = {"weak": wp.component_shares, "weak_el": wp.element_shares, "modal_f": ma.frequencies_hz,
             "modal_shapes": ma.shapes, "modal_dominant": ma.dominant, **{k: analyses[k](st) for k in
                                                                        ("freq", "comp", "stiff", "defl")}}
    assert max(small_chunk) <= 7
    chunks = [(sl, s) for sl, s in iter_structures(hexaglide, x)]
    assert [sl.start for sl, _ in chunks] == [0, 7, 14, 21, 28]
    for key, f in analyses.items():
        for sl, s in chunks:
            if s.empty:
                assert np.isnan(whole[key][sl]).all(), key
            else:
                np.testing.assert_array_equal(whole[key][sl], f(s), err_msg=key)
    assert wp.component_labels and ma.dof_labels  # labels from a part with modelled poses
    np.testing.assert_array_equal(evaluate_structure(hexaglide, st, 0.1, 4).stiffness,
                                  evaluate_structure(hexaglide, x, 0.1, 4, chunk_size=7).stiffness)


def test_part_by_part_without_any_modelled_pose(hexaglide, small_chunk):
    """Every part empty: NaN results of the full length, as for one part."""
    x = np.tile([0.0, 5.0, -1.0, 0.0, 0.0, 0.0], (16, 1))  # unreachable
    st = build_structure(hexaglide, x)
    assert st.empty and len(st.parts()) == 3
    wp = weak_points(st, "x", 0.1)
    assert wp.component_shares.shape[0] == 16 and np.isnan(wp.component_shares).all()
    comp = tcp_compliance(st, 0.1)
    assert comp.shape == (16, 6, 6) and np.isnan(comp).all()
    assert np.isnan(modal_analysis(st, 3).frequencies_hz).all()


def test_derived_machine_data_does_not_keep_machines_alive(hexaglide):
    """Joint-type arrays and components rebuilt for a modified machine live with that machine object (memo), not in
    a module dict keyed by id() (which kept every machine alive) nor in the frozen machine's shared dict."""
    import dataclasses
    import gc
    import weakref

    from pkmstiff.machine.roles import component

    m = dataclasses.replace(hexaglide, components={k: dict(v) for k, v in hexaglide.components.items()})
    arrays = m.joint_type_arrays("drive")
    assert m.joint_type_arrays("drive") is arrays and not arrays["normal"].flags.writeable
    name = next(iter(m.components))
    original = hexaglide.built_components[name]
    built = component(m, name)  # its raw table is a copy: built anew
    assert component(m, name) is built and built is not original[1]
    assert hexaglide.built_components[name] is original  # the dict the copies share was not written to
    ref = weakref.ref(m)
    del m
    gc.collect()
    assert ref() is None
