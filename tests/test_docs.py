"""The documentation runs: every ```python block of README.md and docs/**/*.md executes, the cheap ```console
commands exit 0 (and print what the page shows, where it shows output), and ``mkdocs build --strict`` succeeds.

One page = one namespace; its blocks run in order in a temporary working directory, so a page may create files
(a machine file, a PNG) that later blocks of the same page use, and nothing is written into the repository.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
import shutil
import subprocess
import sys
import types
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
SKIP_MARK = "<!-- skip-test -->"
_FENCE = re.compile(r"^```(\w*)\s*$")


def fenced_blocks(path: Path) -> list[tuple[str, int, str, bool]]:
    """(language, first line number, code, marked skip-test) of every fenced block of a Markdown file."""
    blocks, lang, start, buf, prev = [], None, 0, [], ""
    skip_next = False
    for no, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if lang is None:
            m = _FENCE.match(line)
            if m:
                lang, start, buf, skip_next = m.group(1), no + 1, [], prev.strip() == SKIP_MARK
            elif line.strip():
                prev = line
        elif line.startswith("```"):
            blocks.append((lang, start, "\n".join(buf), skip_next))
            lang, prev = None, ""
        else:
            buf.append(line)
    return blocks


def _page_id(path: Path) -> str:
    return str(path.relative_to(ROOT))


@pytest.fixture()
def isolated(tmp_path, monkeypatch):
    """Temporary cwd, off-screen plotting, and the global registries restored afterwards."""
    import matplotlib

    matplotlib.use("Agg")  # a test may choose the back-end; library code never does
    import pyvista

    monkeypatch.setattr(pyvista, "OFF_SCREEN", True)
    from components import registry
    from pkmstiff.evaluation import quantities

    models = dict(registry._REGISTRY)
    qty = dict(quantities._REGISTRY) if hasattr(quantities, "_REGISTRY") else None
    monkeypatch.chdir(tmp_path)
    yield tmp_path
    registry._REGISTRY.clear()
    registry._REGISTRY.update(models)
    if qty is not None:
        quantities._REGISTRY.clear()
        quantities._REGISTRY.update(qty)
    import matplotlib.pyplot as plt

    plt.close("all")


PYTHON_PAGES = [p for p in PAGES if any(b[0] == "python" and not b[3] for b in fenced_blocks(p))]


@pytest.mark.parametrize("page", PYTHON_PAGES, ids=_page_id)
def test_python_blocks_run(page: Path, isolated, monkeypatch) -> None:
    # a real module, so that classes defined on the page (dataclasses) find their module
    module = types.ModuleType("pkmstiff_docs_page")
    monkeypatch.setitem(sys.modules, module.__name__, module)
    namespace = module.__dict__
    for lang, line, code, skip in fenced_blocks(page):
        if lang != "python" or skip:
            continue
        try:
            exec(compile(code, f"{_page_id(page)}:{line}", "exec"), namespace)
        except Exception as exc:  # name the block, then fail with the original traceback
            raise AssertionError(f"{_page_id(page)}, python block at line {line} failed: {exc!r}") from exc


def console_commands(code: str) -> list[tuple[list[str], list[str]]]:
    """(argv after 'pkmstiff', expected output lines) for every '$ pkmstiff ...' command of a console block."""
    out: list[tuple[list[str], list[str]]] = []
    lines = code.splitlines()
    if not any(line.startswith("$ ") for line in lines):  # a block without prompts: every 'pkmstiff ...' line
        lines = ["$ " + line if line.startswith("pkmstiff ") else line for line in lines]
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("$ "):
            cmd = line[2:]
            while cmd.endswith("\\") and i + 1 < len(lines):
                i += 1
                cmd = cmd[:-1] + " " + lines[i].strip()
            words = shlex.split(cmd, comments=True)
            expected = []
            while i + 1 < len(lines) and not lines[i + 1].startswith("$ "):
                i += 1
                expected.append(lines[i])
            if words and words[0] == "pkmstiff":
                out.append((words[1:], expected))
        i += 1
    return out


#: a number in a console line: not part of a name ("chain1", "O1", "hexapod_6x"), optional sign, decimals, exponent
_NUMBER = re.compile(r"(?<![\w.])[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?(?!\w)")
#: Printed quantities carry the rounding of the BLAS/LAPACK, compiler and library versions and the stopping point of
#: iterative solvers (LM, Newton): on today's newest releases the pages' values moved by up to 6e-4 relative (a
#: parameter of σ/value ≈ 0.25, identified at cond ≈ 2e5). 1e-3 covers that and one unit in the 4th significant
#: digit (the "%.4g" prints), while any change of a model, formula or unit moves the numbers by far more.
_RTOL = 1e-3


def _is_count(token: str) -> bool:
    """Integers of up to 3 digits are counts, ranks, indices, chain numbers: compared exactly. Longer integers are
    "%.4g" prints of quantities (a condition number 9911, an RMS 3091 µm) and take the tolerance like decimals."""
    digits = token.lstrip("+-")
    return digits.isdigit() and len(digits) <= 3


def _last_digit_unit(token: str) -> float:
    """One unit in the last printed digit of a number as printed ("0.25" -> 0.01, "1.2e+04" -> 1e3, "42" -> 1)."""
    mantissa, _, exponent = token.lstrip("+-").lower().partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    return 10.0 ** (int(exponent or 0) - decimals)


def _numbers_agree(expected: str, actual: str) -> bool:
    if _is_count(expected) or _is_count(actual):
        return expected.lstrip("+") == actual.lstrip("+")
    e, a = float(expected), float(actual)
    # one unit in the last printed digit as the absolute floor: values printed near zero with fixed decimals
    return abs(e - a) <= max(_RTOL * max(abs(e), abs(a)), _last_digit_unit(expected))


#: counts set by an iterative solver's stopping test (scipy's least_squares stops when the cost changes by less than
#: ftol — a decision at rounding level on the last step): "8 evaluations" on one machine is "7" on another. Such a
#: count may differ by 25 % (at least 2); every other count is exact.
_SOLVER_COUNT = re.compile(r"\s+evaluations\b")


def _solver_count_agrees(expected: str, actual: str) -> bool:
    e, a = int(expected), int(actual)
    return abs(e - a) <= max(2, 0.25 * e)


def _line_matches(expected: str, actual: str) -> bool:
    """Text between the numbers equal; numbers by :func:`_numbers_agree` (solver counts: :data:`_SOLVER_COUNT`)."""
    if _NUMBER.sub("#", expected) != _NUMBER.sub("#", actual):
        return False
    for e, a in zip(_NUMBER.finditer(expected), _NUMBER.finditer(actual)):
        if _SOLVER_COUNT.match(expected, e.end()) and e.group().isdigit() and a.group().isdigit():
            if not _solver_count_agrees(e.group(), a.group()):
                return False
        elif not _numbers_agree(e.group(), a.group()):
            return False
    return True


def _lines_match(expected: list[str], actual: list[str]) -> bool:
    return len(expected) == len(actual) and all(_line_matches(e, a) for e, a in zip(expected, actual))


def _matches(expected: list[str], actual: list[str]) -> bool:
    """Line by line (trailing blanks ignored; numbers by :func:`_line_matches`); a line '...' stands for any number
    of lines."""
    expected = [e.rstrip() for e in expected if e.strip()]
    actual = [a.rstrip() for a in actual if a.strip()]
    if not expected:
        return True
    if "..." in expected:
        k = expected.index("...")
        head, tail = expected[:k], expected[k + 1:]
        return len(actual) >= len(head) + len(tail) and _lines_match(head, actual[:len(head)]) and (
            not tail or _lines_match(tail, actual[-len(tail):]))
    return _lines_match(expected, actual)


CONSOLE = [(p, line, argv, expected) for p in PAGES for lang, line, code, skip in fenced_blocks(p)
           if lang == "console" and not skip for argv, expected in console_commands(code)]

#: a page with this line runs its console commands in order in one working directory, so that a command can read
#: the files an earlier one wrote (the calibration walkthrough: plan -> simulate -> identify -> check -> report)
CHAIN_MARK = "<!-- docs-test: one working directory -->"
_CHAIN_DIRS: dict[Path, tuple[Path, int]] = {}  # page -> (its working directory, commands run there so far)


def _chained(page: Path) -> bool:
    return CHAIN_MARK in page.read_text(encoding="utf-8")


def _run_cli(argv: list[str]) -> tuple[int, str]:
    from pkmstiff.cli import main

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        try:
            status = main(argv)
        except SystemExit as exc:  # --help exits through argparse
            status = exc.code or 0
    return status, buf.getvalue()


def _chain_dir(page: Path, line: int, argv: list[str], factory) -> Path:
    """The page's shared working directory with every earlier command of the page run in it (also when this test
    runs alone, e.g. with -k)."""
    cmds = [(ln, a) for p, ln, a, _ in CONSOLE if p == page]
    k = cmds.index((line, argv))
    d, done = _CHAIN_DIRS.get(page) or (factory.mktemp("chain"), 0)
    cwd = os.getcwd()
    os.chdir(d)
    try:
        for ln, a in cmds[done:k]:
            status, _ = _run_cli(a)
            assert status == 0, f"{_page_id(page)}:{ln}: earlier command 'pkmstiff {' '.join(a)}' exited {status}"
    finally:
        os.chdir(cwd)
    _CHAIN_DIRS[page] = (d, k + 1)
    return d


@pytest.mark.parametrize("page,line,argv,expected", CONSOLE,
                         ids=[f"{_page_id(c[0])}:{c[1]}:{' '.join(c[2][:2])}" for c in CONSOLE])
def test_console_commands_run(page: Path, line: int, argv: list[str], expected: list[str], isolated, monkeypatch,
                              tmp_path_factory) -> None:
    if _chained(page):
        monkeypatch.chdir(_chain_dir(page, line, argv, tmp_path_factory))
    status, out = _run_cli(argv)
    buf = io.StringIO(out)
    assert status == 0, f"{_page_id(page)}:{line}: 'pkmstiff {' '.join(argv)}' exited with {status}"
    assert _matches(expected, buf.getvalue().splitlines()), (
        f"{_page_id(page)}:{line}: output of 'pkmstiff {' '.join(argv)}' differs from the page:\n{buf.getvalue()}")


def test_readme_is_short_and_keeps_the_setup_commands() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 250  # the manual lives in docs/; the README is the overview
    # .ci/run runs the second command; both are the promised set-up
    assert 'pip install . && pkmstiff demo' in text
    assert 'pip install ".[test]" && python -m pytest' in text


def test_console_block_parser() -> None:
    cmds = console_commands('$ pkmstiff pose hexaglide --pose 0,0,-1000,0,0,0   # comment\nline 1\n...\n'
                            '$ pkmstiff section hx \\\n    --plane yz\n$ ls')
    assert cmds == [(["pose", "hexaglide", "--pose", "0,0,-1000,0,0,0"], ["line 1", "..."]),
                    (["section", "hx", "--plane", "yz"], [])]
    assert _matches(["a", "...", "z"], ["a", "b", "c", "z"]) and not _matches(["a", "...", "z"], ["a", "b"])
    assert _matches(["a", "b"], ["a", "b  "]) and not _matches(["a", "b"], ["a", "c"])


def test_console_numbers_compare_with_the_documented_tolerance() -> None:
    line = "rank 36 of 42, cond 1.175e+04, RMS 3091 -> 0.2515 µm, chain1.base_joint.x -0.361804 mrad, mean 0.01 µm"
    assert _matches([line], [line.replace("1.175e+04", "1.176e+04").replace("3091", "3093")
                             .replace("-0.361804", "-0.361589").replace("0.01 µm", "0.02 µm")])
    for changed in ("rank 35", "of 43", "1.275e+04", "3121", "0.2535", "chain2.base", "-0.3631", "0.03 µm", "mrad,"):
        old = {"rank 35": "rank 36", "of 43": "of 42", "1.275e+04": "1.175e+04", "3121": "3091", "0.2535": "0.2515",
               "chain2.base": "chain1.base", "-0.3631": "-0.361804", "0.03 µm": "0.01 µm", "mrad,": "mrad"}[changed]
        assert not _matches([line], [line.replace(old, changed, 1)]), changed
    assert _matches(["x 1.0e-3"], ["x 1.0005e-3"]) and not _matches(["8 readings"], ["7 readings"])
    assert _matches(["8 evaluations"], ["7 evaluations"]) and not _matches(["8 evaluations"], ["12 evaluations"])


def test_every_page_is_in_the_nav() -> None:
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    pages = [p.relative_to(ROOT / "docs").as_posix() for p in (ROOT / "docs").rglob("*.md")]
    assert pages
    missing = [p for p in pages if f" {p}" not in nav]
    assert not missing, f"pages not in the mkdocs.yml nav: {missing}"


def test_mkdocs_build_strict(tmp_path) -> None:
    if shutil.which("mkdocs") is None and not _has_module("mkdocs"):
        pytest.skip("mkdocs is not installed (it comes with the 'test' extra: pip install '.[test]')")
    if not _has_module("material"):
        pytest.skip("mkdocs-material is not installed (it comes with the 'test' extra: pip install '.[test]')")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
                         cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, f"mkdocs build --strict failed:\n{run.stdout}\n{run.stderr}"
    cli = (tmp_path / "site" / "reference" / "cli" / "index.html").read_text(encoding="utf-8")
    assert "pkmstiff workspace" in cli and "--resolution" in cli  # the generated reference is in the site
    cat = (tmp_path / "site" / "reference" / "components" / "index.html").read_text(encoding="utf-8")
    assert "ballscrew_fixed_fixed" in cat


def _has_module(name: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(name) is not None


# ---------------------------------------------------------------------------------------- '# -> output' comments
#: a statement of a ```python block whose last line ends with this comment must print what follows it
OUTPUT_MARK = "# -> "
#: numbers in a `# ->` comment (digits inside names count: the text around them is compared separately)
_COMMENT_NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


def _same_printed_line(expected: str, actual: str) -> bool:
    """Text equal (whitespace ignored: numpy pads columns), numbers equal within one unit of the expected number's
    last printed digit: a value on a rounding boundary may round either way under another BLAS or numpy, whose
    results differ by ~1e-12 relative; a stale comment differs by far more."""
    exp_nums, act_nums = _COMMENT_NUMBER.findall(expected), _COMMENT_NUMBER.findall(actual)
    if re.sub(r"\s+", "", _COMMENT_NUMBER.sub("#", expected)) != re.sub(r"\s+", "", _COMMENT_NUMBER.sub("#", actual)):
        return False
    for e, a in zip(exp_nums, act_nums):
        if abs(float(a) - float(e)) > 1.01 * _last_digit_unit(e):
            return False
    return len(exp_nums) == len(act_nums)


def output_comments(code: str) -> dict[int, str]:
    """Line number (1-based, in ``code``) -> expected output of every '# -> ...' comment."""
    import tokenize

    return {tok.start[0]: tok.string[len(OUTPUT_MARK):].strip()
            for tok in tokenize.generate_tokens(io.StringIO(code).readline)
            if tok.type == tokenize.COMMENT and tok.string.startswith(OUTPUT_MARK)}


COMMENTED_PAGES = [p for p in PAGES if any(b[0] == "python" and not b[3] and output_comments(b[2])
                                           for b in fenced_blocks(p))]


@pytest.mark.parametrize("page", COMMENTED_PAGES, ids=_page_id)
def test_python_output_comments(page: Path, isolated, monkeypatch) -> None:
    """Every '# -> text' comment of a page's python blocks states what its statement prints (so the comments of the
    README's examples cannot go stale); the blocks run statement by statement, in order, in one namespace."""
    import ast

    module = types.ModuleType("pkmstiff_docs_page")
    monkeypatch.setitem(sys.modules, module.__name__, module)
    wrong = []
    for lang, line, code, skip in fenced_blocks(page):
        if lang != "python" or skip:
            continue
        expected = output_comments(code)
        for stmt in ast.parse(code).body:
            buf = io.StringIO()
            with contextlib.redirect_stdout(buf):
                exec(compile(ast.Module([stmt], []), f"{_page_id(page)}:{line}", "exec"), module.__dict__)
            want = next((expected[n] for n in range(stmt.lineno, stmt.end_lineno + 1) if n in expected), None)
            if want is not None and not _same_printed_line(want, buf.getvalue().strip()):
                wrong.append(f"{_page_id(page)}:{line + stmt.end_lineno - 1}: the comment says {want!r}, "
                             f"the statement prints {buf.getvalue().strip()!r}")
    assert not wrong, "\n".join(wrong)


def test_output_comment_comparison() -> None:
    assert output_comments("x = 1\nprint(x)  # -> 1\n# a comment\n") == {2: "1"}
    assert _same_printed_line("[24.82  4.42 43.5 ] N/um", "[24.82 4.43 43.5] N/um")  # one unit of the last digit
    assert not _same_printed_line("[3.428 4.253 4.506]", "[4.369 4.813 5.188]")  # the stale README comment
    assert not _same_printed_line("57.6 %", "57.6 Hz") and not _same_printed_line("1 2", "1 2 3")
    assert _same_printed_line("1.5e+04", "1.49e4") and not _same_printed_line("1.5e+04", "1.7e4")
