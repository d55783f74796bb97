"""Both report kinds built small and fast, and looked at in headless Chromium as a reader sees them (issue 28 item 4):
``pkmstiff report`` (two Hexaglide variants, one coarse section, a coarse workspace, a weighted evaluation) and
``pkmstiff calibrate report`` (a small simulated Felix ballbar measurement). Used by tests/test_app_browser.py and by
docs/make_images.py (the reports' screenshots in docs/images)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from tests.report_checks import _ABSOLUTE, _MARKDOWN  # the HTML checks' markers, here on the rendered text

ROOT = Path(__file__).resolve().parents[1]

#: the width a report is read at (the docs' screenshots and the overflow check)
WIDTH = 1400
#: the tallest screenshot (a report's first screens: title, summary, tables, the first figures)
MAX_HEIGHT = 2000

DESIGN_SPEC = """
[report]
title = "Hexaglide: original vs. softer struts"
summary = "Two variants of the Hexaglide on a coarse raster: the original and one with 100 N/um struts."
baseline = "original"
machine_rows = ["transmission_weight", "tool_length"]

[[variants]]
name = "original"
machine = "hexaglide"

[[variants]]
name = "soft struts"
machine = "hexaglide"
overrides = { "components.strut_950.k" = "100 N/um", "components.strut_1000.k" = "100 N/um" }

[workspace]
resolution_mm = 200

[[sections]]
plane = "yz"
at_mm = 0
range = "y=-600:1600,z=-1400:-300"
step_mm = 100
quantities = ["kx", "U"]
statistics = ["min", "mean", "max", "area"]

[[points]]
pose = [0, 400, -1000, 0, 0, 0]
quantities = ["kx", "f1"]

[[evaluation]]
metric = "kx mean"
weight = 2

[[evaluation]]
metric = "U mean"
"""

CALIBRATION_PLAN = """
[plan]
name = "small Felix hemisphere and circle"
instrument = "ballbar"

[setup]
fixed_ball = ["0 mm", "0 mm", "0 mm"]
bar_length = "300 mm"
measuring_range = "15 mm"

[[paths]]
kind = "hemisphere"
points = 60
turns = 2
tilt = "20 deg"
torsion = "15 deg"

[[paths]]
kind = "circle"
plane = "XY"
centre = ["0 mm", "0 mm", "150 mm"]
radius = "259.808 mm"
points = 36
"""


def _pkmstiff(folder: Path, *argv: str) -> tuple[subprocess.Popen, Path]:
    """``pkmstiff ARGV`` started in ``folder`` (paths relative to it, as a user types them: the report records the
    command line); the process and its log."""
    log = folder / f"{argv[0]}-{argv[1]}.log"
    with log.open("w") as fh:
        proc = subprocess.Popen([sys.executable, "-m", "pkmstiff.cli", *argv], cwd=folder, stdout=fh,
                                stderr=subprocess.STDOUT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    return proc, log


def _wait(started: tuple[subprocess.Popen, Path]) -> None:
    proc, log = started
    if proc.wait() != 0:
        raise RuntimeError(f"pkmstiff {' '.join(proc.args[3:])} exited with {proc.returncode}: {log.read_text()}")


def build_reports(folder: Path) -> tuple[Path, Path]:
    """The design report of :data:`DESIGN_SPEC` (``pkmstiff report design.toml --out design``) and the calibration
    report of :data:`CALIBRATION_PLAN` (``pkmstiff calibrate simulate felix`` with the example errors, seed 1, then
    ``pkmstiff calibrate report felix --out calibration``), built side by side in ``folder``; their HTML files."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "design.toml").write_text(DESIGN_SPEC, encoding="utf-8")
    (folder / "plan.toml").write_text(CALIBRATION_PLAN, encoding="utf-8")
    design = _pkmstiff(folder, "report", "design.toml", "--out", "design", "--quiet")
    _wait(_pkmstiff(folder, "calibrate", "simulate", "felix", "--plan", "plan.toml", "--errors",
                    "example:felix_errors.toml", "--seed", "1", "--feed", "3000", "--sample-rate", "5", "--out",
                    "meas.csv"))
    _wait(_pkmstiff(folder, "calibrate", "report", "felix", "--measurements", "meas.csv", "--plan", "plan.toml",
                    "--out", "calibration"))
    _wait(design)
    return folder / "design" / "report.html", folder / "calibration" / "report.html"


#: what the page shows, measured in the browser: the visible text, every image's natural width, and the tables (and
#: the page) wider than the window
_LOOK = """
const root = document.documentElement;
return {
  text: document.body.innerText,
  images: Array.from(document.images).map(i => [i.alt || i.src.slice(0, 40), i.complete ? i.naturalWidth : 0]),
  page_overflow: root.scrollWidth - root.clientWidth,
  wide_tables: Array.from(document.querySelectorAll('table'))
    .filter(t => t.getBoundingClientRect().right > root.clientWidth + 0.5
                 || t.scrollWidth > t.parentElement.clientWidth + 0.5)
    .map(t => (t.innerText || '').slice(0, 60)),
  height: Math.max(document.body.scrollHeight, root.scrollHeight),
};
"""

def look_at(driver, html: Path, screenshot: Path) -> list[str]:
    """Open ``html`` at :data:`WIDTH` px, save a screenshot of its first :data:`MAX_HEIGHT` px to ``screenshot`` and
    return what a reader would find wrong (empty: nothing): raw Markdown or absolute paths in the visible text,
    images that did not load, tables or a page wider than the window."""
    driver.set_window_size(WIDTH, 1000)
    driver.get(html.resolve().as_uri())
    seen = driver.execute_script(_LOOK)
    driver.set_window_size(WIDTH, min(MAX_HEIGHT, int(seen["height"])) + 140)  # + the window's frame
    driver.save_screenshot(str(screenshot))
    problems = []
    for pat in _MARKDOWN:
        problems += [f"raw Markdown in the text: {m.group(0)!r}" for m in pat.finditer(seen["text"])]
    problems += [f"absolute path in the text: {seen['text'][max(0, m.start() - 40):m.end() + 40]!r}"
                 for m in _ABSOLUTE.finditer(seen["text"])]
    problems += [f"image not loaded: {name}" for name, width in seen["images"] if not width]
    problems += [f"table wider than the {WIDTH} px window: {t!r}" for t in seen["wide_tables"]]
    if seen["page_overflow"] > 0:
        problems.append(f"the page is {seen['page_overflow']} px wider than the {WIDTH} px window")
    if not seen["images"]:
        problems.append("no images")
    return problems
