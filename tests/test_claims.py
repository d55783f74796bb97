"""README/docs claims are recomputed, not typed (issue 12, item 7), and the demo's window holds the whole admissible
YZ region (issue 12, "Done when")."""

from __future__ import annotations

import json
from pathlib import Path

from pkmstiff.cli.claims import CLAIMS_FILE, ROOT, collect_claims, readme_block, render_markdown


def test_claims_file_is_up_to_date():
    stored = json.loads(CLAIMS_FILE.read_text(encoding="utf-8"))
    assert collect_claims() == stored, ("docs/claims.json is out of date: check the change, then run "
                                        "'python -m pkmstiff.cli.claims --write' and update the README block")


def test_readme_block_matches_when_present():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    block = readme_block(readme)
    if block is not None:  # the README carries the generated block between the claims markers
        assert block == render_markdown()


def test_demo_writes_exactly_the_listed_files_and_its_window_holds_the_region(tmp_path, capsys, hexaglide):
    from pkmstiff.cli import main
    from pkmstiff.evaluation.sections import evaluate_section
    from pkmstiff.report.demo import output_files
    from pkmstiff.workspace.windows import window_for

    # default raster step (10 mm): no admissible point on the window's edge, so nothing of the region is cut off
    res = evaluate_section(hexaglide, window_for(hexaglide, "yz", 0.0, 0.01), [])
    assert res.ok.sum() > 3000 and res.touching_edges() == []
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--step", "40", "--quiet"]) == 0
    assert sorted(p.name for p in Path(out).iterdir()) == sorted(output_files())
    text = capsys.readouterr().out
    assert f"and {len(output_files()) - 2} figure/data files" in text and "warning" not in text
    assert main(["demo", "--out", str(out), "--step", "40", "--quiet"]) == 2  # no silent overwrite
    assert "--force" in capsys.readouterr().err


def test_workspace_guide_quotes_the_generated_rotation_map_counts():
    from pkmstiff.cli.claims import rotation_map_sentence

    claims = json.loads(CLAIMS_FILE.read_text(encoding="utf-8"))
    text = " ".join((ROOT / "docs" / "user-guide" / "workspace.md").read_text(encoding="utf-8").split())
    assert rotation_map_sentence(claims) in text


def _fe_examples() -> list[tuple[str, str]]:
    """(command, parameter file) of every fe-joint / fe-platform example in the README and the docs."""
    import re

    out = []
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        for cmd, arg in re.findall(r"pkmstiff (fe-joint|fe-platform) (\S+)", page.read_text(encoding="utf-8")):
            if not arg.startswith(("my_", "-", "PARAMS")):
                out.append((cmd, arg))
    return out


def test_fe_example_parameter_files_work_from_any_directory(tmp_path, monkeypatch):
    from pkmstiff.fe import load_joint_parameters, load_platform_parameters

    examples = _fe_examples()
    assert {c for c, _ in examples} == {"fe-joint", "fe-platform"}
    monkeypatch.chdir(tmp_path)  # not the clone's root
    for cmd, arg in examples:
        load = load_joint_parameters if cmd == "fe-joint" else load_platform_parameters
        assert load(arg).source.endswith(".toml"), arg
    for name in ("iwf_3dof_improved", "hexaglide_platform.toml"):  # shipped names, as the help says
        assert (load_joint_parameters if name.startswith("iwf") else load_platform_parameters)(name)


def test_platform_paste_recipe_with_extends(tmp_path, monkeypatch):
    # docs/user-guide/fe.md: the TOML of 'pkmstiff fe-platform ... --out platform_fe.toml', pasted into a machine file
    # that extends the Hexaglide, replaces the Hexaglide's K_U (whose 'diagonal' is not inherited next to 'matrix')
    import numpy as np

    from pkmstiff.cli import main
    from pkmstiff.machine.loader import load_machine

    monkeypatch.chdir(tmp_path)
    assert main(["fe-platform", "pkmstiff/fe/params/hexaglide_platform.toml", "--mesh-size", "60",
                 "--out", "platform_fe.toml", "--quiet"]) == 0
    pasted = (tmp_path / "platform_fe.toml").read_text(encoding="utf-8")
    machine_file = tmp_path / "hexaglide_fe_platform.toml"
    machine_file.write_text('[machine]\nextends = "hexaglide"\nname = "hexaglide_fe_platform"\n\n' + pasted,
                            encoding="utf-8")
    m = load_machine(machine_file)
    k_u = m.built_components["platform_stiffness"][1].matrix
    import tomllib

    table = np.array(tomllib.loads(pasted)["components"]["platform_stiffness"]["matrix"])
    # translational block written in N/um with 6 significant digits: read back exactly as written
    np.testing.assert_allclose(k_u[:3, :3], table[:3, :3] * 1e6, rtol=1e-15)
    assert not np.allclose(np.diag(k_u), np.diag(load_machine("hexaglide").built_components["platform_stiffness"][1].matrix))
