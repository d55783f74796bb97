"""FE validation against closed-form beam results with a 3-level mesh-convergence study (issue item 2).

A slender steel bar (square a x a, length L = 20 a) is clamped at x = 0; its end face x = L is coupled
rigidly (RBE2) to a reference point on the axis; Guyan condensation gives the 6x6 tip stiffness K. From
the compliance C = K^-1 (other tip DOFs unloaded):

* axial     1/C_xx  vs EA/L,
* bending   1/C_yy  vs 1/(L^3/(3EI) + L/(kappa G A))  (Timoshenko, kappa = 10(1+nu)/(12+11nu), Cowper),
* torsion   1/C_rxrx vs GJ/L, J = Saint-Venant torsion constant of the square (series).

Three meshes (hex20: 10x1x1, 20x2x2, 40x4x4 elements). Tolerances (issue: <= 2 % bar and torsion,
<= 3 % cantilever at the finest mesh) are justified by the study itself: the deviation must decrease from
level to level and the change between the two finest levels (an estimate of the remaining discretisation
error) must be well inside the tolerance; what remains is the end effect of the clamp and the rigid
coupling (they suppress the Poisson contraction and the warping), which is O(a/L) and not a mesh error.
Measured (hex20): axial 0.77 / 0.48 / 0.36 %, bending 1.83 / 0.75 / 0.47 %, torsion 18.6 / 1.93 / 0.36 %.
"""

import numpy as np
import pytest

from pkmstiff.fe import mesh as fm
from pkmstiff.fe.assembly import NodeSet, Part, PartModel, ReferencePoint
from pkmstiff.fe.materials import Isotropic

E, NU = 210e9, 0.3
A_SIDE, L = 0.02, 0.4
STEEL = Isotropic("steel", E, NU)
LEVELS = [(10, 1), (20, 2), (40, 4)]


def square_torsion_constant(a: float) -> float:
    n = np.arange(1, 200, 2)
    return a**4 * (1 / 3 - 64 / np.pi**5 * np.sum(np.tanh(n * np.pi / 2) / n**5))


def references():
    G = E / (2 * (1 + NU))
    area, inertia = A_SIDE**2, A_SIDE**4 / 12
    kappa = 10 * (1 + NU) / (12 + 11 * NU)
    return {"axial": E * area / L,
            "bending": 1 / (L**3 / (3 * E * inertia) + L / (kappa * G * area)),
            "torsion": G * square_torsion_constant(A_SIDE) / L}


def tip_stiffness(nx: int, ny: int) -> dict[str, float]:
    m = fm.box((0, -A_SIDE / 2, -A_SIDE / 2), (L, A_SIDE / 2, A_SIDE / 2), 1.0, n=(nx, ny, ny))
    model = PartModel([Part("bar", m, STEEL)], clamps=[NodeSet("bar", lambda x: x[0] < 1e-9)],
                      references=[ReferencePoint("tip", (L, 0, 0), NodeSet("bar", lambda x: x[0] > L - 1e-9))])
    C = np.linalg.inv(model.condense().K)
    return {"axial": 1 / C[0, 0], "bending": 1 / C[1, 1], "torsion": 1 / C[3, 3]}


@pytest.fixture(scope="module")
def study():
    ref = references()
    return [{k: v / ref[k] - 1 for k, v in tip_stiffness(nx, ny).items()} for nx, ny in LEVELS]


TOLERANCE = {"axial": 0.02, "torsion": 0.02, "bending": 0.03}


@pytest.mark.parametrize("case", ["axial", "bending", "torsion"])
def test_closed_form_within_tolerance_at_the_finest_mesh(study, case):
    dev = [abs(level[case]) for level in study]
    print(f"{case}: deviations per mesh level " + ", ".join(f"{d * 100:.2f} %" for d in dev))
    assert dev[-1] <= TOLERANCE[case]
    # converging: every refinement reduces the deviation
    assert dev[0] >= dev[1] >= dev[2]
    # converged: the last refinement changes the result by less than the tolerance
    assert abs(study[2][case] - study[1][case]) <= TOLERANCE[case]


def test_coarse_mesh_is_measurably_off(study):
    """The study is sensitive: one element across the section is visibly worse in torsion (> 5 %)."""
    assert abs(study[0]["torsion"]) > 0.05
