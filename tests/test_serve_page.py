"""The live page of ``mse serve`` (GET / on the server's port) in a real headless Chromium: a
click on an emotion makes the face change (compared on screenshots), a sentence is said."""

from __future__ import annotations

import time
import urllib.error
import urllib.request
from typing import Any

import pytest

pytest.importorskip("websockets")

from tests.serve_server import BackgroundServer


@pytest.mark.slow
def test_the_page_is_served_and_other_paths_are_not_found() -> None:
    with BackgroundServer() as server:
        page = urllib.request.urlopen(f"http://127.0.0.1:{server.server.port}/", timeout=30)
        assert page.headers["Content-Type"].startswith("text/html") and b'data-emotion="anger"' in page.read()
        with pytest.raises(urllib.error.HTTPError) as missing:
            urllib.request.urlopen(f"http://127.0.0.1:{server.server.port}/secret", timeout=30)
        assert missing.value.code == 404


def _wait(condition: Any, seconds: float) -> Any:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError("timed out")


@pytest.mark.slow
def test_a_click_on_an_emotion_changes_the_face(driver: Any) -> None:
    from selenium.webdriver.common.by import By

    with BackgroundServer() as server:
        driver.get(f"http://127.0.0.1:{server.server.port}/")
        _wait(lambda: "choose an emotion" in driver.find_element(By.ID, "status").text, 30)
        box = driver.find_element(By.ID, "face-box")
        driver.find_element(By.CSS_SELECTOR, 'button[data-emotion="tension"]').click()
        _wait(lambda: driver.find_element(By.TAG_NAME, "body").get_attribute("data-face-time"), 30)
        first = box.screenshot_as_png
        changed = _wait(lambda: box.screenshot_as_png != first, 15)  # the face plays the episode
        assert changed
        clicked = time.monotonic()
        before = box.screenshot_as_png
        driver.find_element(By.CSS_SELECTOR, 'button[data-emotion="anger"]').click()
        _wait(lambda: box.screenshot_as_png != before, 15)
        assert time.monotonic() - clicked < 15
        driver.find_element(By.ID, "say-text").send_keys("I did not expect that at all")
        driver.find_element(By.ID, "say").click()
        time.sleep(0.5)
        assert "error" not in driver.find_element(By.ID, "status").text
        assert int(driver.find_element(By.TAG_NAME, "body").get_attribute("data-occurrences")) > 0
