"""``pose``/``point`` JSON documents validate against the shipped JSON Schemas (pkmstiff/schemas), and the schema
identifier each document carries matches its schema's ``const``."""

from __future__ import annotations

import json

import numpy as np
import pytest

jsonschema = pytest.importorskip("jsonschema")

from pathlib import Path  # noqa: E402

import pkmstiff  # noqa: E402
from pkmstiff.cli import main  # noqa: E402

#: the schemas are package data (pyproject: pkmstiff/schemas/*.json); every document names its schema in "schema"
SCHEMAS = Path(pkmstiff.__file__).resolve().parent / "schemas"


def load_schema(command: str) -> dict:
    return json.loads((SCHEMAS / f"{command}.schema.json").read_text(encoding="utf-8"))


def _json(capsys, *argv) -> dict:
    assert main(list(argv)) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("command", ["pose", "point"])
def test_schemas_are_valid_json_schema(command):
    schema = load_schema(command)
    jsonschema.Draft202012Validator.check_schema(schema)
    assert schema["properties"]["schema"]["const"] == f"pkmstiff/{command}/1"


def test_pose_document_validates(capsys):
    doc = _json(capsys, "pose", "hexaglide", "--pose", "-100,300,-1000,0,0,5", "--json")
    jsonschema.validate(doc, load_schema("pose"))
    assert doc["admissible"] is True and doc["reasons"] == []


def test_point_document_validates_and_stiffness_matrix_is_symmetric(capsys):
    doc = _json(capsys, "point", "hexaglide", "--pose", "0,300,-900,0,0,0", "--modes", "3", "--json")
    jsonschema.validate(doc, load_schema("point"))
    k = np.array(doc["stiffness_matrix_SI"])
    # Maxwell–Betti: K is symmetric; the inverse of a symmetric compliance keeps symmetry to ~1e-12 relative
    np.testing.assert_allclose(k, k.T, rtol=1e-9, atol=1e-9 * np.abs(k).max())
    # the diagonal entries k_x.. in N/µm are 1/C_ii, not K_ii: K_ii >= 1/C_ii for a positive definite K
    for i, ax in enumerate("xyz"):
        assert k[i, i] >= doc["k_N_per_um"][ax] * 1e6 * (1 - 1e-12)
    doc = _json(capsys, "point", "hexaglide", "--pose", "0,0,-900,0,0,0", "--modes", "1", "--json",
                "--allow-inadmissible")
    jsonschema.validate(doc, load_schema("point"))
    assert doc["admissible"] is False and doc["analysed_although_inadmissible"] is True and doc["reasons"]


def test_planar_point_document_validates(capsys):
    doc = _json(capsys, "point", "bipod", "--pose", "0,-707", "--json")
    jsonschema.validate(doc, load_schema("point"))


@pytest.mark.parametrize("argv", [["hexa_6rus", "--pose", "20,-30,-420,3,-2,5"], ["five_bar", "--pose", "90,310,0"],
                                  ["hybrid_tripod_wrist", "--pose", "0,100,-1073.2,10,0,0", "--tool-length", "50"]])
def test_mechanism_point_documents_validate(capsys, argv):
    """Mechanisms: rotary drive torques, controlled outputs, planar pose (phi_deg) are in the schema."""
    doc = _json(capsys, "point", *argv, "--modes", "2", "--json")
    jsonschema.validate(doc, load_schema("point"))
