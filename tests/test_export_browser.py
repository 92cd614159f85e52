"""The HTML viewer in a real headless Chromium (Debian ``chromium`` + ``chromium-driver``).

One browser for the whole module; skipped with a reason when Chromium, its driver or
selenium is missing (CI installs them, see docs/export.md).
"""

from __future__ import annotations

import base64
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mse.export import ExportOptions
from mse.export.figures import FigureClip
from mse.export.html import render_html
from mse.timeline import Timeline, loads_many

FIXTURE = Path(__file__).resolve().parent / "fixtures" / "export" / "embarrassment_timeline.json"
CHROME_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--window-size=1280,900",
)


def _binary(*names: str) -> str | None:
    for name in names:
        found = shutil.which(name)
        if found:
            return found
    return None


@pytest.fixture(scope="module")
def driver() -> Iterator[Any]:
    webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is not installed")
    browser = _binary("chromium", "chromium-browser")
    chromedriver = _binary("chromedriver")
    if browser is None or chromedriver is None:
        pytest.skip("chromium/chromedriver not found: apt-get install -y chromium chromium-driver")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = browser
    for flag in CHROME_FLAGS:
        options.add_argument(flag)
    with tempfile.TemporaryDirectory(prefix="mse-chromium-") as profile:
        options.add_argument(f"--user-data-dir={profile}")
        instance = webdriver.Chrome(service=Service(chromedriver), options=options)
        try:
            yield instance
        finally:
            instance.quit()


@pytest.fixture(scope="module")
def timeline() -> Timeline:
    return loads_many(FIXTURE.read_text(encoding="utf-8"), path=str(FIXTURE))[0]


@pytest.fixture(scope="module")
def page(tmp_path_factory: pytest.TempPathFactory, timeline: Timeline) -> Path:
    """The viewer with a waving stick figure on the first gaze occurrence (0 s - 2.1 s)."""
    frames = 90
    angle = np.linspace(0.0, 4.0 * np.pi, frames)
    positions = np.zeros((frames, 5, 3))
    positions[:, 0] = (0.0, 100.0, 0.0)  # hips
    positions[:, 1] = (0.0, 150.0, 0.0)  # neck
    positions[:, 2, 0] = 30.0 * np.cos(angle)  # hand circling round the neck
    positions[:, 2, 1] = 150.0 + 30.0 * np.sin(angle)
    positions[:, 3] = (-15.0, 50.0, 0.0)
    positions[:, 4] = (15.0, 50.0, 0.0)
    first = timeline.signals[0]
    clip = FigureClip(
        first.id, first.lexeme, first.start, first.stop, 30.0,
        ("hips", "neck", "hand", "left_foot", "right_foot"), (-1, 0, 1, 0, 0), positions,
    )  # fmt: skip
    path = tmp_path_factory.mktemp("viewer") / "viewer.html"
    path.write_text(render_html(timeline, ExportOptions(), [clip]), encoding="utf-8")
    return path


def _loaded(driver: Any, page: Path) -> Any:
    driver.get(page.as_uri())
    return driver


def test_one_bar_per_signal_and_hover_shows_times(driver: Any, page: Path, timeline: Timeline) -> None:
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    browser = _loaded(driver, page)
    bars = browser.find_elements(By.CSS_SELECTOR, "#timeline g.bar")
    assert len(bars) == len(timeline.signals)
    tooltip = browser.find_element(By.ID, "tooltip")
    assert not tooltip.is_displayed()
    target = next(b for b in bars if b.get_attribute("data-id") == "6")
    ActionChains(browser).move_to_element(target).perform()
    assert tooltip.is_displayed()
    assert "start 1.2 s" in tooltip.text and "stop 3.7 s" in tooltip.text
    assert "embarrassment_signal_6" in tooltip.text


#: Decodes a PNG (base64) in the browser and returns [distinct colours, non-white share].
_PIXEL_STATS = """
const done = arguments[arguments.length - 1];
const image = new Image();
image.onload = () => {
  const canvas = document.createElement("canvas");
  canvas.width = image.width;
  canvas.height = image.height;
  const context = canvas.getContext("2d");
  context.drawImage(image, 0, 0);
  const data = context.getImageData(0, 0, canvas.width, canvas.height).data;
  const seen = new Set();
  let inked = 0;
  for (let i = 0; i < data.length; i += 4) {
    seen.add((data[i] << 16) | (data[i + 1] << 8) | data[i + 2]);
    if (data[i] < 235 || data[i + 1] < 235 || data[i + 2] < 235) { inked += 1; }
  }
  done([seen.size, inked / (data.length / 4)]);
};
image.onerror = () => done([0, 0]);
image.src = "data:image/png;base64," + arguments[0];
"""


def test_screenshot_is_not_blank(driver: Any, page: Path) -> None:
    from selenium.webdriver.common.by import By

    browser = _loaded(driver, page)
    png = browser.find_element(By.ID, "layout").screenshot_as_png
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    colours, inked = browser.execute_async_script(_PIXEL_STATS, base64.b64encode(png).decode())
    assert colours > 50
    assert inked > 0.03


def test_playhead_and_stick_figure_advance(driver: Any, page: Path) -> None:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    browser = _loaded(driver, page)
    playhead = browser.find_element(By.ID, "playhead")
    figure = browser.find_element(By.ID, "figure")
    x_before = float(playhead.get_attribute("x1"))
    assert figure.get_attribute("data-clip") == "0"  # the clip starts at 0 s
    frame_before = int(figure.get_attribute("data-frame"))
    browser.find_element(By.ID, "play").click()
    clock = browser.find_element(By.ID, "clock")
    WebDriverWait(browser, 5).until(lambda _: float(clock.get_attribute("data-time")) > 0.5)
    browser.find_element(By.ID, "play").click()  # pause
    assert float(playhead.get_attribute("x1")) > x_before
    assert int(figure.get_attribute("data-frame")) > frame_before
    paused_at = clock.get_attribute("data-time")
    browser.execute_script("return new Promise(r => setTimeout(r, 150));")
    assert clock.get_attribute("data-time") == paused_at
