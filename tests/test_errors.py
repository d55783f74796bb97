"""Errors by kind (issue 21 item 6): every error class derives from one of the few kinds, each kind has one exit
status, messages are built from fields, and no caller sorts errors by their message text."""

from __future__ import annotations

import ast
import inspect
import pickle
from pathlib import Path

import pytest

from pkmstiff import errors
from pkmstiff.cli import EXIT_STATUS, exit_status, main
from pkmstiff.errors import ArgumentError, InadmissibleError, InputError, NumericalError, PkmstiffError, ResourceError
from pkmstiff.io import read_toml

ROOT = Path(__file__).resolve().parents[1]
KINDS = (InputError, ArgumentError, ResourceError, NumericalError, InadmissibleError)
SOURCES = sorted([*(ROOT / "pkmstiff").rglob("*.py"), *(ROOT / "components").rglob("*.py")])


def _classes() -> list[tuple[Path, ast.ClassDef]]:
    return [(p, node) for p in SOURCES for node in ast.walk(ast.parse(p.read_text(encoding="utf-8")))
            if isinstance(node, ast.ClassDef)]


def _base_names(node: ast.ClassDef) -> list[str]:
    return [b.id if isinstance(b, ast.Name) else b.attr if isinstance(b, ast.Attribute) else "" for b in node.bases]


def test_every_error_class_of_errors_py_derives_from_one_kind():
    defined = [c for _, c in inspect.getmembers(errors, inspect.isclass)
               if issubclass(c, Exception) and c.__module__ == errors.__name__]
    assert set(KINDS) <= set(defined)
    for cls in defined:
        if cls is PkmstiffError:
            continue
        assert sum(issubclass(cls, k) for k in KINDS) == 1, cls  # exactly one kind, so one exit status


def test_no_error_class_is_defined_outside_errors_py_except_as_a_kind():
    """A module keeps a class of its own only where a caller must tell it apart, and then it derives from a kind."""
    exception_bases = {"Exception", "ValueError", "TypeError", "RuntimeError", "KeyError", "ImportError", "OSError",
                       "ArithmeticError", "LookupError"}
    kind_names = {k.__name__ for k in KINDS} | {"PkmstiffError"}
    errors_py = ROOT / "pkmstiff" / "errors.py"
    shadows = [f"{p.relative_to(ROOT)}: {c.name}" for p, c in _classes() if p != errors_py and c.name in kind_names]
    assert not shadows, shadows  # a module's own class named like a kind would hide it
    offenders = []
    for path, node in _classes():
        if path == errors_py:
            continue
        bases = set(_base_names(node))
        is_error = bases & exception_bases or node.name.endswith(("Error", "Exception"))
        if is_error and not bases & (kind_names | {n for n, _ in inspect.getmembers(errors, inspect.isclass)}):
            offenders.append(f"{path.relative_to(ROOT)}: class {node.name}({', '.join(sorted(bases))})")
    assert not offenders, offenders


@pytest.mark.parametrize("kind,status", [(InputError, 2), (ArgumentError, 2), (ResourceError, 2),
                                         (NumericalError, 2), (InadmissibleError, 3)])
def test_each_kind_maps_to_its_exit_status(kind, status):
    assert EXIT_STATUS[kind] == status and exit_status(kind()) == status
    for sub in (c for _, c in inspect.getmembers(errors, inspect.isclass) if c is not kind and issubclass(c, kind)):
        assert exit_status(sub()) == status, sub


def test_the_command_line_exits_by_kind(capsys):
    # inadmissible pose: 3 (docs/user-guide/cli-output.md); a bad option value: 2; both one line on stderr
    assert main(["point", "hexaglide", "--pose", "2000,0,-1000,0,0,0"]) == 3
    assert "is not admissible" in capsys.readouterr().err
    assert main(["point", "hexaglide", "--pose", "1,2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--pose: expected six finite numbers" in err


def test_input_messages_are_built_from_fields():
    e = InputError("m.toml", "chains.kind", "'pod' or 'glide'", "hexapod")
    assert str(e) == "m.toml: key 'chains.kind': expected 'pod' or 'glide', found 'hexapod'"
    assert (e.file, e.key, e.expected, e.found, e.line) == ("m.toml", "chains.kind", "'pod' or 'glide'", "hexapod",
                                                            None)
    e = InputError("m.csv", "reading_mm", line=9, column=8, reason="expected a number, found 'x'")
    assert str(e) == "m.csv: line 9, column 8 (reading_mm): expected a number, found 'x'"
    assert str(InputError(reason="too few samples", file="b.csv")) == "b.csv: too few samples"
    named = InputError("", "k", "a number", None).in_file("f.toml")
    assert str(named) == "f.toml: key 'k': expected a number, found None"
    # a file named already stays named
    assert InputError("a.toml", "k", "x", 1).in_file("b.toml").file == "a.toml"


def test_argument_messages_are_built_from_fields():
    e = ArgumentError(option="--alpha", expected="a probability in (0, 1)", found=1.5)
    assert str(e) == "--alpha: expected a probability in (0, 1), found 1.5"
    e = ArgumentError(option="--range", found=None, expected="MIN < MAX")  # None is a finding, not "no finding"
    assert str(e) == "--range: expected MIN < MAX, found None"
    assert str(ArgumentError("plane axes must be orthogonal")) == "plane axes must be orthogonal"
    e = ArgumentError("not writable", option="--out")
    assert str(e) == "--out: not writable" and e.detail == "not writable"  # a file key may stand for the option


@pytest.mark.parametrize("exc", [InputError("m.toml", "k", "a length", "3 apples", line=4),
                                 InputError("m.csv", "t_s", line=3, column=1, reason="time must not decrease"),
                                 ArgumentError(option="--pose", expected="six numbers", found="1,2"),
                                 InadmissibleError("pose 1 not admissible"), NumericalError("did not converge")])
def test_errors_survive_pickling_with_their_fields(exc):
    """Worker processes (sweeps, reports) send errors back pickled: the same message and fields arrive."""
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is type(exc) and str(back) == str(exc) and back.__dict__ == exc.__dict__


def test_the_toml_reader_names_file_line_and_column(tmp_path):
    p = tmp_path / "m.toml"
    p.write_text('[machine]\nname = "x"\n[chains\n', encoding="utf-8")
    with pytest.raises(InputError) as err:
        read_toml(p, "machine file")
    e = err.value
    assert (e.file, e.key, e.line, e.column) == (str(p), "(file)", 3, 8)
    assert str(e).startswith(f"{p}: line 3, column 8: key '(file)': expected valid TOML, found ") and "\n" not in str(e)
    with pytest.raises(InputError, match=r"key '\(file\)': expected an existing plan file .*, found 'no such file'"):
        read_toml(tmp_path / "missing.toml", "plan file")


def test_machine_file_errors_name_file_and_key(tmp_path):
    from pkmstiff import load_machine

    p = tmp_path / "m.toml"
    p.write_text('[machine]\nextends = "hexaglide"\n[chains]\nkind = "hexapod"\n', encoding="utf-8")
    with pytest.raises(InputError) as err:
        load_machine(str(p))
    assert (err.value.file, err.value.key, err.value.found) == (str(p), "chains", {"kind": "hexapod"})
    assert str(err.value).startswith(f"{p}: key 'chains': expected an array of 6 [[chains]] tables")


def _sorts_by_text(handler: ast.ExceptHandler) -> bool:
    """Does the handler compare ``... in str(exc)`` (or ``exc.args``) to decide what to do?"""
    if not handler.name:
        return False
    for node in ast.walk(ast.Module(body=handler.body, type_ignores=[])):
        if isinstance(node, ast.Compare) and any(isinstance(op, (ast.In, ast.NotIn)) for op in node.ops):
            for side in (node.left, *node.comparators):
                if (isinstance(side, ast.Call) and isinstance(side.func, ast.Name) and side.func.id == "str"
                        and side.args and isinstance(side.args[0], ast.Name) and side.args[0].id == handler.name):
                    return True
                if (isinstance(side, ast.Attribute) and side.attr == "args" and isinstance(side.value, ast.Name)
                        and side.value.id == handler.name):
                    return True
                if any(isinstance(n, ast.Attribute) and n.attr == "__name__" for n in ast.walk(side)):
                    return True  # "override" in type(exc).__name__.lower()
    return False


def test_no_except_sorts_errors_by_message_text():
    offenders = [f"{p.relative_to(ROOT)}:{h.lineno}" for p in SOURCES
                 for h in ast.walk(ast.parse(p.read_text(encoding="utf-8"))) if isinstance(h, ast.ExceptHandler)
                 and _sorts_by_text(h)]
    assert not offenders, offenders


def test_the_text_sorting_check_can_fail():
    tree = ast.parse("try:\n    f()\nexcept ValueError as exc:\n    if 'converge' in str(exc):\n        raise\n")
    assert _sorts_by_text(next(n for n in ast.walk(tree) if isinstance(n, ast.ExceptHandler)))
    tree = ast.parse("try:\n    f()\nexcept ValueError as exc:\n    k = 'a' if 'override' in type(exc).__name__.lower() else 'b'\n")
    assert _sorts_by_text(next(n for n in ast.walk(tree) if isinstance(n, ast.ExceptHandler)))
