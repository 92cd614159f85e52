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


@pytest.mark.slow
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


@pytest.mark.slow
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


# -- the face player ----------------------------------------------------------------------
FACE_SIGNALS = (
    ("smile", "face", "faceexp=smile", 1.0, 3.0),
    ("head_left", "head", "head=head_left", 4.0, 6.0),
    ("gaze_down", "gaze", "gaze=look_down", 7.0, 8.5),
    ("blink", "face", "faceexp=blink", 9.0, 9.3),
)
NEUTRAL, SMILING, TURNED, LOOKING_DOWN, BLINKING = 0.5, 2.0, 5.0, 7.75, 9.15


@pytest.fixture(scope="module")
def face_timeline() -> Timeline:
    from mse.timeline import TimelineSignal

    return Timeline("face test", 10.0, tuple(TimelineSignal(*s) for s in FACE_SIGNALS), solver="hand-made")


@pytest.fixture(scope="module")
def face_page(tmp_path_factory: pytest.TempPathFactory, face_timeline: Timeline) -> Path:
    path = tmp_path_factory.mktemp("face") / "face.html"
    path.write_text(render_html(face_timeline, ExportOptions(), []), encoding="utf-8")
    return path


def _at(browser: Any, time: float) -> None:
    browser.execute_script(
        "const s = document.getElementById('scrub'); s.value = arguments[0];"
        "s.dispatchEvent(new Event('input'));",
        time,
    )
    assert float(browser.find_element("id", "face").get_attribute("data-time")) == pytest.approx(time, abs=1e-3)


def _face_shot(browser: Any, time: float) -> np.ndarray:
    import io

    from PIL import Image

    _at(browser, time)
    png = browser.find_element("id", "face").screenshot_as_png
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(np.int16)


def _box(browser: Any, *shapes: str) -> tuple[int, int, int, int]:
    """Screen box (relative to the face SVG) round the named shapes, a little enlarged."""
    script = (
        "const svg = document.getElementById('face').getBoundingClientRect();"
        "const boxes = arguments[0].map(id => document.querySelector(`path[data-shape='${id}']`)"
        ".getBoundingClientRect());"
        "return [Math.min(...boxes.map(b => b.left)) - svg.left, Math.min(...boxes.map(b => b.top)) - svg.top,"
        " Math.max(...boxes.map(b => b.right)) - svg.left, Math.max(...boxes.map(b => b.bottom)) - svg.top];"
    )
    left, top, right, bottom = browser.execute_script(script, list(shapes))
    return int(left) - 4, int(top) - 4, int(right) + 4, int(bottom) + 4


def _region(image: np.ndarray, box: tuple[int, int, int, int]) -> np.ndarray:
    left, top, right, bottom = box
    return image[max(top, 0) : bottom, max(left, 0) : right]


def _changed(a: np.ndarray, b: np.ndarray) -> int:
    return int((np.abs(a - b).max(axis=2) > 40).sum())


def test_face_is_drawn_and_not_blank(driver: Any, face_page: Path) -> None:
    browser = _loaded(driver, face_page)
    image = _face_shot(browser, NEUTRAL)
    colours = len(np.unique(image.reshape(-1, 3), axis=0))
    assert colours > 200
    background = np.array([0xE9, 0xEE, 0xF2])
    assert (np.abs(image - background).max(axis=2) > 20).mean() > 0.3  # a face, not an empty panel


def test_smile_changes_the_mouth(driver: Any, face_page: Path) -> None:
    browser = _loaded(driver, face_page)
    _at(browser, NEUTRAL)
    mouth = _box(browser, "lip.upper", "lip.lower")
    neutral, smiling = _face_shot(browser, NEUTRAL), _face_shot(browser, SMILING)
    assert _changed(_region(neutral, mouth), _region(smiling, mouth)) > 100
    eyes_far_from_mouth = _box(browser, "brow.L", "brow.R")
    assert _changed(_region(neutral, eyes_far_from_mouth), _region(smiling, eyes_far_from_mouth)) < 60
    assert _changed(_face_shot(browser, 1.5), _face_shot(browser, 2.5)) == 0  # the apex holds


def test_head_left_turns_the_head(driver: Any, face_page: Path) -> None:
    browser = _loaded(driver, face_page)
    _at(browser, NEUTRAL)
    nose_before = _box(browser, "nose")
    neutral = _face_shot(browser, NEUTRAL)
    turned = _face_shot(browser, TURNED)
    nose_after = _box(browser, "nose")
    # The agent's left is the viewer's right: the nose moves right.
    assert (nose_after[0] + nose_after[2]) / 2 - (nose_before[0] + nose_before[2]) / 2 > 8
    head = _box(browser, "face")
    assert _changed(_region(neutral, head), _region(turned, head)) > 2000


def test_gaze_down_moves_the_eyes(driver: Any, face_page: Path) -> None:
    browser = _loaded(driver, face_page)
    _at(browser, NEUTRAL)
    iris_before = _box(browser, "iris.L", "iris.R")
    eyes = _box(browser, "sclera.L", "sclera.R")
    neutral = _face_shot(browser, NEUTRAL)
    down = _face_shot(browser, LOOKING_DOWN)
    iris_after = _box(browser, "iris.L", "iris.R")
    assert iris_after[1] - iris_before[1] > 2  # the irises move down
    assert abs(iris_after[0] - iris_before[0]) <= 1  # ... not sideways
    assert _changed(_region(neutral, eyes), _region(down, eyes)) > 80


def test_blink_closes_the_lids(driver: Any, face_page: Path) -> None:
    browser = _loaded(driver, face_page)
    _at(browser, NEUTRAL)
    eyes = _box(browser, "sclera.L", "sclera.R")

    def iris_pixels(image: np.ndarray) -> int:
        region = _region(image, eyes)
        blue = (region[..., 2] > region[..., 0] + 40) & (region[..., 2] > 120)
        white = region.min(axis=2) > 235
        return int(blue.sum() + white.sum())

    assert iris_pixels(_face_shot(browser, NEUTRAL)) > 150
    assert iris_pixels(_face_shot(browser, BLINKING)) < 10


@pytest.mark.slow
def test_page_and_video_draw_the_same_face(driver: Any, face_page: Path, face_timeline: Timeline) -> None:
    """face.js and the numpy evaluator give the same paths; the SVG and the aggdraw frame
    look the same (anti-aliasing differs only at edges)."""
    import re

    from mse.export.face.page import face_track
    from mse.export.face.raster import face_image
    from mse.export.face.rig import default_rig, pose_points, shape_paths

    browser = _loaded(driver, face_page)
    rig = default_rig()
    track = face_track(face_timeline, ExportOptions())
    shots = {}
    for time in (NEUTRAL, 1.15, SMILING, 4.2, TURNED, LOOKING_DOWN, BLINKING):
        page_paths = browser.execute_script("return window.mseFace.paths(arguments[0]);", time)
        values = track.values(np.array([time]))[0]
        python_paths = shape_paths(rig, pose_points(rig, values), values)
        assert len(page_paths) == len(python_paths)
        for (page_d, page_alpha), (python_d, python_alpha) in zip(page_paths, python_paths, strict=True):
            page_numbers = [float(n) for n in re.findall(r"-?\d+\.\d+", page_d)]
            python_numbers = [float(n) for n in re.findall(r"-?\d+\.\d+", python_d)]
            assert len(page_numbers) == len(python_numbers)
            assert np.allclose(page_numbers, python_numbers, atol=0.011)
            assert page_alpha == pytest.approx(python_alpha, abs=1e-9)
        shot = _face_shot(browser, time)
        height, width = shot.shape[:2]
        frame = np.asarray(face_image(rig, values, (width, height))).astype(np.int16)
        shots[time] = (shot, frame)
        # Anti-aliasing differs a little along edges (Skia and AGG), nothing else.
        assert float(np.abs(shot - frame).mean()) < 3.0, time
        assert _changed(shot, frame) < 0.01 * width * height, time
    # Each screenshot is recognised among the frames: its own moment is the nearest by far.
    for time, (shot, frame) in shots.items():
        own = _coarse_distance(shot, frame)
        others = [_coarse_distance(shot, other) for t, (_, other) in shots.items() if t != time]
        assert own < 35 and own < min(others) / 1.5, (time, own, others)


def _coarse_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Largest difference of 4x4-pixel means: blind to anti-aliasing, not to shapes."""
    height, width = (a.shape[0] // 4) * 4, (a.shape[1] // 4) * 4

    def coarse(image: np.ndarray) -> np.ndarray:
        return image[:height, :width].reshape(height // 4, 4, width // 4, 4, 3).mean(axis=(1, 3))

    return float(np.abs(coarse(a) - coarse(b)).max())


def test_page_plays_saccades_and_merged_occurrences_as_python_does(
    driver: Any, tmp_path_factory: pytest.TempPathFactory
) -> None:
    """face.js mirrors track.py's saccades (look_around) and the one hold of back-to-back
    occurrences of a lexeme."""
    from mse.export.face.page import face_track
    from mse.timeline import TimelineSignal

    signals = (
        TimelineSignal("scan", "gaze", "gaze=look_around", 0.5, 4.5),
        TimelineSignal("a", "face", "faceexp=jaw_clench", 0.0, 2.0),
        TimelineSignal("b", "face", "faceexp=jaw_clench", 2.05, 4.0),
    )
    timeline = Timeline("saccades", 5.0, signals, solver="hand-made")
    path = tmp_path_factory.mktemp("saccades") / "saccades.html"
    path.write_text(render_html(timeline, ExportOptions(), []), encoding="utf-8")
    browser = _loaded(driver, path)
    track = face_track(timeline, ExportOptions())
    times = [0.3 + 0.037 * i for i in range(120)]
    page = np.array(browser.execute_script("return arguments[0].map(t => window.mseFace.channels(t));", times))
    assert np.allclose(page, track.values(np.array(times)), atol=1e-9)
