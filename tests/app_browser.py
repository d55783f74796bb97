"""Driving ``pkmstiff app`` in headless Chromium (Selenium): start the app on a free port in a subprocess, open it,
work its controls as a user does. Used by tests/test_app_browser.py and by docs/make_images.py (the app's
screenshots in docs/images)."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: Debian's chromium and chromium-driver (.ci/run installs them), else what PATH offers
BROWSERS = ("/usr/bin/chromium", "chromium", "chromium-browser", "google-chrome")
DRIVERS = ("/usr/bin/chromedriver", "chromedriver")
WINDOW = (1600, 1200)


def find(names) -> str | None:
    return next((p for p in (shutil.which(n) for n in names) if p), None)


def missing_browser() -> str | None:
    """Why no browser test can run here (None if Chromium and chromedriver are found)."""
    if find(BROWSERS) is None:
        return "Chromium not found (Debian: apt-get install chromium chromium-driver; tried " + ", ".join(BROWSERS) + ")"
    if find(DRIVERS) is None:
        return "chromedriver not found (Debian: apt-get install chromium-driver; tried " + ", ".join(DRIVERS) + ")"
    return None


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def running_app(out: Path, machine: str = "hexaglide", timeout: float = 60.0, step_mm: float = 25.0):
    """``pkmstiff app MACHINE --port P --no-browser --out OUT --step STEP`` in a subprocess; yields (url, process,
    port)."""
    port = free_port()
    log = open(out / "app.log", "w")
    proc = subprocess.Popen([sys.executable, "-m", "pkmstiff.cli", "app", machine, "--port", str(port), "--no-browser",
                             "--out", str(out), "--step", f"{step_mm:g}"], cwd=ROOT, stdout=log, stderr=subprocess.STDOUT,
                            env={**os.environ, "PYTHONPATH": str(ROOT)})
    url = f"http://127.0.0.1:{port}/"
    try:
        end = time.monotonic() + timeout
        while True:
            if proc.poll() is not None:
                raise RuntimeError(f"pkmstiff app exited with {proc.returncode}: {(out / 'app.log').read_text()}")
            with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", port), timeout=1):
                break
            if time.monotonic() > end:
                raise TimeoutError(f"pkmstiff app did not listen on {url} within {timeout:g} s")
            time.sleep(0.2)
        yield url, proc, port
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
        log.close()


@contextlib.contextmanager
def chromium():
    """A headless Chromium driven by Selenium, window :data:`WINDOW`."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
                f"--window-size={WINDOW[0]},{WINDOW[1]}"):
        opts.add_argument(arg)
    opts.binary_location = find(BROWSERS)
    driver = webdriver.Chrome(service=Service(find(DRIVERS)), options=opts)
    try:
        yield driver
    finally:
        driver.quit()


def text(driver, element_id: str) -> str:
    return driver.find_element("id", element_id).get_attribute("textContent").strip()


def wait_for(driver, condition, what: str, timeout: float = 60.0):
    """Poll ``condition(driver)`` until it is truthy; fail naming ``what`` and the app's status and error."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        with contextlib.suppress(Exception):
            got = condition(driver)
            if got:
                return got
        time.sleep(0.2)
    raise TimeoutError(f"waited {timeout:g} s for {what}; status {text(driver, 'status')!r}, "
                       f"error {text(driver, 'error')!r}")


def geometry(driver) -> dict:
    return json.loads(text(driver, "map-geometry") or "{}")


def wait_map(driver, after_version: int = 0, quantity: str | None = None) -> dict:
    """Wait for a section map newer than ``after_version`` (of ``quantity``) with the app ready; its geometry."""
    def ready(d):
        g = geometry(d)
        return g if (g.get("version", 0) > after_version and text(d, "status") == "ready"
                     and (quantity is None or g["quantity"] == quantity)) else None

    return wait_for(driver, ready, f"a section map after version {after_version}")


def type_into(driver, element_id: str, value: str) -> None:
    from selenium.webdriver.common.keys import Keys

    box = driver.find_element("id", element_id)
    box.send_keys(Keys.CONTROL, "a")
    box.send_keys(value)
    box.send_keys(Keys.TAB)


def click(driver, find_element, what: str) -> None:
    """Click the element ``find_element(driver)`` returns, again until the click lands: a list that is still fading
    out (Vuetify's transition) can lie over it for a moment and intercept the click."""
    def clicked(d):
        element = find_element(d)
        if element is None:
            return False
        element.click()  # raises ElementClickInterceptedException while covered; wait_for polls again
        return True

    wait_for(driver, clicked, what)


def press(driver, element_id: str) -> None:
    """Click the button or checkbox ``element_id`` (retried while a fading list covers it, see :func:`click`)."""
    click(driver, lambda d: d.find_element("id", element_id), f"a click on {element_id}")


def choose(driver, element_id: str, item: str) -> None:
    """Open the select ``element_id`` (a click on its field: the input itself lies under the shown selection) and
    click its list item ``item``."""
    def no_open_list(d):
        return not any(e.is_displayed() for e in d.find_elements("css selector", ".v-overlay-container .v-list"))

    wait_for(driver, no_open_list, f"the lists to close before opening {element_id}")
    click(driver, lambda d: d.find_element("id", element_id).find_element(
        "xpath", "./ancestor::div[contains(concat(' ', @class, ' '), ' v-field ')][1]"), f"the field {element_id}")

    def item_element(d):
        return next((e for e in d.find_elements("css selector", ".v-overlay-container .v-list-item")
                     if e.is_displayed() and e.text.strip() == item), None)

    click(driver, item_element, f"the item {item!r} of {element_id}")


def click_map(driver, u_mm: float, v_mm: float) -> None:
    """Click the section map picture at the in-plane position (u, v) [mm], from the map's axes box."""
    from selenium.webdriver import ActionChains

    g = geometry(driver)
    left, top, right, bottom = g["axes_px"]
    u0, u1, v0, v1 = g["limits_mm"]
    width, height = g["size_px"]
    x = left + (u_mm - u0) / (u1 - u0) * (right - left)
    y = top + (v1 - v_mm) / (v1 - v0) * (bottom - top)
    img = driver.find_element("id", "section-map")
    shown = img.size
    ActionChains(driver).move_to_element_with_offset(
        img, int(round(x * shown["width"] / width - shown["width"] / 2)),
        int(round(y * shown["height"] / height - shown["height"] / 2))).click().perform()
