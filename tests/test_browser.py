"""The explorer in a real browser: Voila serves a notebook that shows ``tofjax.explorer()`` on
127.0.0.1, and Playwright drives Debian's Chromium (headless) through what a user does: change a
value and see the preview redraw, enter an invalid value and see the message at the field (outlined
red), run Calculate and see the plots, zoom into one and export its curves, cancel a long run, save
and load a TOML file, render a frame in the Frame tab (analytic, then Monte Carlo). Screenshots of each step
are kept in ``test-artifacts/browser/`` (or ``$TOFJAX_TEST_ARTIFACTS/browser``).

Needs playwright, voila and a Chromium (``$TOFJAX_CHROMIUM``, else /usr/bin/chromium); without them
the test is skipped, unless ``TOFJAX_BROWSER_TEST=required`` (as `.ci/run` sets it, after installing
them), where a missing piece fails it.
"""

import os
import re
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = os.environ.get("TOFJAX_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"
# Chromium as root in a container, on a machine without outside network (its background requests
# are refused, many at a time, without these flags).
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync"]
START_S = 180  # a cold kernel: import JAX, compile the previews


def _requirements():
    missing = []
    for module in ("playwright", "voila"):
        try:
            __import__(module)
        except ImportError:
            missing.append(f"{module} (pip install {module})")
    if not Path(CHROMIUM).exists():
        missing.append(f"Chromium at {CHROMIUM} (apt-get install chromium)")
    if missing:
        message = "the browser test needs " + ", ".join(missing)
        if os.environ.get("TOFJAX_BROWSER_TEST") == "required":
            pytest.fail(message)
        pytest.skip(message)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def voila(tmp_path):
    """Voila serving a notebook with the explorer at the defaults, in ``tmp_path`` (the kernel's
    working directory: the TOML files go there); yields (url, folder); stopped afterwards."""
    import nbformat  # here, not at collection: it imports jsonschema's format checkers (2 s)

    _requirements()
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell("import tofjax as tj\nex = tj.explorer()\nex")])
    nbformat.write(nb, tmp_path / "explorer.ipynb")
    port = _free_port()
    log = open(tmp_path / "voila.log", "w")  # noqa: SIM115 - closed below
    server = subprocess.Popen([sys.executable, "-m", "voila", "--no-browser", f"--port={port}", "--Voila.ip=127.0.0.1",
                               "--show_tracebacks=True", "explorer.ipynb"], cwd=tmp_path, stdout=log,
                              stderr=subprocess.STDOUT, env={**os.environ, "MPLBACKEND": "Agg"})
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                socket.create_connection(("127.0.0.1", port), 0.5).close()
                break
            except OSError:
                if server.poll() is not None or time.monotonic() > deadline:
                    pytest.fail(f"voila did not start: {(tmp_path / 'voila.log').read_text()[-2000:]}")
                time.sleep(0.2)
        yield f"http://127.0.0.1:{port}/", tmp_path
    finally:
        server.terminate()
        try:
            server.wait(10)
        except subprocess.TimeoutExpired:
            server.kill()
        log.close()


def _artifacts() -> Path:
    base = Path(os.environ.get("TOFJAX_TEST_ARTIFACTS", ROOT / "test-artifacts"))
    folder = base / "browser"
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.glob("*.png"):  # this run's screenshots only
        old.unlink()
    return folder


def _field(page, dotted: str):
    section, name = dotted.split(".")
    return page.locator(f".tofjax-key-{section}-{name}")


def _enter(page, dotted: str, value: str) -> None:
    box = _field(page, dotted).locator("input").first
    box.fill(value)
    box.press("Enter")


def test_the_explorer_in_a_browser(voila):
    from playwright.sync_api import expect, sync_playwright

    url, folder = voila
    shots = _artifacts()
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=FLAGS)
        page = browser.new_page(viewport={"width": 1280, "height": 800})
        page.set_default_timeout(60_000)
        # Its expectations too (5 s by default): a loaded machine took longer to show a plot's canvas.
        expect.set_options(timeout=60_000)
        try:
            page.goto(url, timeout=START_S * 1000)
            calculate = page.get_by_role("button", name="Calculate")
            expect(calculate).to_be_visible(timeout=START_S * 1000)
            expect(calculate).to_be_enabled()
            page.screenshot(path=shots / "1_opened.png")

            # A value changes the preview: the waveform picture of the Pixel tab is redrawn.
            page.get_by_role("tab", name="Pixel").click()
            preview = page.locator(".tofjax-waveform-preview")
            expect(preview).to_be_visible()
            page.wait_for_function("() => document.querySelector('.tofjax-waveform-preview').naturalWidth > 0")
            expect(page.locator(".tofjax-correlation-preview")).to_be_visible()
            before = preview.get_attribute("src")
            _enter(page, "illumination_waveform.duty_cycle", "0.3")
            expect(preview).not_to_have_attribute("src", before)
            page.screenshot(path=shots / "2_preview_changed.png")

            # An invalid value: the message at the field, the field highlighted, Calculate disabled.
            _enter(page, "pixel.v_saturated_v", "3.5")
            field = _field(page, "pixel.v_saturated_v")
            expect(field).to_contain_text("must be less than pixel.v_reset_v")
            expect(field).to_have_class(re.compile("tofjax-invalid"))
            outline = field.evaluate("e => getComputedStyle(e).borderTopColor")
            assert outline == "rgb(204, 0, 0)", outline  # outlined red
            page.screenshot(path=shots / "3_invalid_value.png")
            _enter(page, "pixel.v_saturated_v", "2.0")
            expect(field).not_to_contain_text("must be less than")

            # Calculate on a small sweep: the plots appear.
            page.get_by_role("tab", name="Main").click()
            expect(calculate).to_be_enabled()
            _enter(page, "scene.samples", "10")
            _enter(page, "pixel.iterations", "100")
            calculate.click()
            plot = page.locator(".tofjax-plots .tofjax-plot")
            expect(plot).to_have_count(3, timeout=120_000)
            expect(page.locator(".tofjax-summary")).to_contain_text("10 samples")
            page.screenshot(path=shots / "4_calculated.png", full_page=True)

            # The plots zoom (ipympl's toolbar): a rectangle dragged on the first one redraws it.
            first = plot.first
            first.scroll_into_view_if_needed()
            canvas = first.locator("canvas").last
            expect(canvas).to_be_visible()
            page.wait_for_timeout(500)  # the first image has arrived
            before = canvas.screenshot()
            canvas.hover()  # the toolbar fades in
            first.get_by_title(re.compile("Zoom to rectangle")).click()
            box = canvas.bounding_box()
            page.mouse.move(box["x"] + 0.3 * box["width"], box["y"] + 0.3 * box["height"])
            page.mouse.down()
            page.mouse.move(box["x"] + 0.5 * box["width"], box["y"] + 0.5 * box["height"], steps=5)
            page.mouse.up()
            page.wait_for_timeout(1000)
            assert canvas.screenshot() != before, "zooming did not redraw the plot"
            page.screenshot(path=shots / "4b_zoomed.png")

            # Each plot exports its curves (into the kernel's folder: the TOML file's).
            page.locator(".tofjax-plots").get_by_role("button", name=re.compile("Export CSV")).nth(2).click()
            expect(page.locator(".tofjax-message")).to_contain_text("distance_depth_noise.csv")
            assert (folder / "distance_depth_noise.csv").read_text().startswith("panel,curve,x_label,x,y_label,y")

            # A long run, cancelled: Calculate is disabled while it goes, the message says cancelled.
            _enter(page, "scene.samples", "1000")
            _enter(page, "pixel.iterations", "200000")
            expect(page.locator(".tofjax-stale-note")).to_contain_text("stale")
            calculate.click()
            expect(calculate).to_be_disabled()
            expect(page.locator(".tofjax-progress")).to_be_visible(timeout=120_000)
            page.screenshot(path=shots / "5_running.png")
            page.get_by_role("button", name="Cancel").click()
            expect(page.locator(".tofjax-message")).to_contain_text("cancelled", timeout=120_000)
            expect(calculate).to_be_enabled()
            page.screenshot(path=shots / "6_cancelled.png")

            # Save, change, load: the saved value comes back; a second save asks first.
            path_box = page.get_by_role("textbox", name="TOML file")
            path_box.fill("saved.toml")
            path_box.press("Enter")
            page.get_by_role("button", name=re.compile(r"^\W*Save$")).click()
            expect(page.locator(".tofjax-message")).to_contain_text("saved")
            assert (folder / "saved.toml").exists()
            _enter(page, "scene.samples", "20")
            page.get_by_role("button", name=re.compile(r"^\W*Save$")).click()
            expect(page.locator(".tofjax-message")).to_contain_text("exists: press Overwrite")
            page.get_by_role("button", name="Load").click()
            expect(page.locator(".tofjax-message")).to_contain_text("loaded")
            expect(_field(page, "scene.samples").locator("input")).to_have_value("1000")
            page.screenshot(path=shots / "7_loaded.png")

            # The Frame tab: the analytic frame of its scene at once, then three Monte Carlo frames.
            page.get_by_role("tab", name="Frame").click()
            page.get_by_role("button", name="Noise image").click()
            expect(page.locator(".tofjax-frame-summary")).to_contain_text("good pixels", timeout=120_000)
            page.wait_for_function("() => document.querySelector('.tofjax-frame-image').naturalWidth > 0")
            frames_box = page.get_by_role("spinbutton", name="Monte Carlo frames")
            frames_box.fill("3")
            frames_box.press("Enter")
            page.get_by_role("button", name="Monte Carlo frames").click()
            expect(page.locator(".tofjax-frame-summary")).to_contain_text("3 Monte Carlo frames", timeout=120_000)
            page.screenshot(path=shots / "8_frame.png")
        except Exception:
            page.screenshot(path=shots / "failed.png", full_page=True)
            raise
        finally:
            browser.close()
