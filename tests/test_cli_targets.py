"""One resolver for what a command's machine argument names (issue 21 item 4): spatial machines, planar examples and
mechanisms reach pose/point/section through pkmstiff.cli.targets, and a command without an evaluator for a kind
answers as for an unknown machine."""

from __future__ import annotations

import pytest

from pkmstiff.cli.targets import Kind, dispatch, resolve


@pytest.mark.parametrize("spec,kind", [("hexaglide", Kind.SPATIAL), ("felix", Kind.SPATIAL),
                                       ("biglide", Kind.PLANAR), ("bipod", Kind.PLANAR),
                                       ("slider_crank", Kind.MECHANISM), ("five_bar", Kind.MECHANISM),
                                       ("no_such_machine", Kind.SPATIAL)])
def test_bundled_names_resolve_to_their_kind(spec, kind):
    assert resolve(spec).kind is kind and resolve(spec).spec == spec


def test_files_resolve_by_their_format(tmp_path):
    from pkmstiff.machine import bundled_machine_dir
    from pkmstiff.mechanisms.loader import bundled_mechanism_dir

    mech = tmp_path / "m.toml"
    mech.write_text((bundled_mechanism_dir() / "slider_crank.toml").read_text(encoding="utf-8"), encoding="utf-8")
    machine = tmp_path / "x.toml"
    machine.write_text((bundled_machine_dir() / "hexaglide.toml").read_text(encoding="utf-8"), encoding="utf-8")
    broken = tmp_path / "broken.toml"
    broken.write_text("[mechanism\n", encoding="utf-8")
    assert resolve(str(mech)).kind is Kind.MECHANISM
    assert resolve(str(machine)).kind is Kind.SPATIAL
    assert resolve(str(broken)).kind is Kind.SPATIAL  # the machine loader reports the syntax error


def test_dispatch_falls_back_to_the_spatial_evaluator():
    table = {Kind.SPATIAL: lambda t: ("spatial", t.kind), Kind.PLANAR: lambda t: ("planar", t.kind)}
    assert dispatch("biglide", table) == ("planar", Kind.PLANAR)
    assert dispatch("slider_crank", table) == ("spatial", Kind.MECHANISM)  # no mechanism evaluator here


def test_commands_keep_their_answers(capsys):
    from pkmstiff.cli import main

    assert main(["point", "biglide", "--pose", "0,600"]) == 0
    assert "planar" in capsys.readouterr().out
    assert main(["pose", "slider_crank", "--pose", "100,0,0"]) in (0, 3)
    assert "slider_crank" in capsys.readouterr().out
    # point evaluates mechanisms with elastic data (issue 27); the slider-crank has none: one line, exit 2
    assert main(["point", "slider_crank", "--pose", "0,0,0"]) == 2
    assert "mechanism 'slider_crank' has no [elastic] table" in capsys.readouterr().err
