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
