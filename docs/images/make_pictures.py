"""Make the README's pictures again: ``python docs/images/make_pictures.py`` (from the checkout).

timeline.svg and face.png are what the commands in docs/export.md ("Regenerating the
pictures") write; viewer.png is a headless-Chromium screenshot (Debian ``chromium`` and
``chromium-driver``, selenium from the dev extra) of the HTML viewer of the same timeline
with the playhead at the face's moment, 1060 px wide, cropped to 710 px, 256 colours.
half-body.png (docs/face.md) is three stills of :func:`mse.export.video.render_stimulus` from a
hand-made timeline: hands on the hips with an angry frown, a bow, a hand on the mouth.
tests/test_docs_examples.py checks that timeline.svg is what the recipe makes.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

SEED = "5461"
AT = "8.4"
IMAGES = Path(__file__).resolve().parent


def mse(*args: str, cwd: Path) -> None:
    subprocess.run([sys.executable, "-m", "mse", *args], cwd=cwd, check=True)


def screenshot(page: Path, target: Path) -> None:
    from PIL import Image
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = shutil.which("chromium") or shutil.which("chromium-browser") or "chromium"
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--window-size=1060,900"):
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(shutil.which("chromedriver") or "chromedriver"), options=options)
    try:
        driver.get(page.as_uri())
        driver.execute_script(
            "const s = document.getElementById('scrub'); s.value = arguments[0];"
            "s.dispatchEvent(new Event('input'));",
            AT,
        )
        raw = page.with_suffix(".png")
        driver.save_screenshot(str(raw))
    finally:
        driver.quit()
    with Image.open(raw) as image:
        image.crop((0, 0, 1060, 710)).convert("RGB").quantize(256).save(target, optimize=True)


def half_body(target: Path) -> None:
    from PIL import Image

    from mse.export.video import render_stimulus
    from mse.timeline import Timeline, TimelineSignal

    signals = (
        TimelineSignal("frown", "face", "faceexp=frown_lips_parted_teeth", 0.0, 2.0),
        TimelineSignal("hips", "gesture", "gesture=hands_on_hips", 0.0, 2.0),
        TimelineSignal("bow", "torso", "torso=bow", 2.0, 4.0),
        TimelineSignal("smile", "face", "faceexp=tensed_smile", 4.0, 6.0),
        TimelineSignal("mouth", "gesture", "gesture=hand_on_mouth", 4.0, 6.0),
    )
    timeline = Timeline("half-body", 6.0, signals, solver="hand-made")
    stills = []
    for index, at in enumerate((1.0, 3.0, 5.0)):
        path = target.with_name(f"still{index}.png")
        render_stimulus(timeline, path, size=(300, 390), still_at=at)
        stills.append(Image.open(path).convert("RGB"))
    sheet = Image.new("RGB", (300 * len(stills), 390))
    for index, still in enumerate(stills):
        sheet.paste(still, (300 * index, 0))
    sheet.quantize(256).save(target, optimize=True)


def main() -> None:
    with tempfile.TemporaryDirectory(prefix="mse-pictures-") as name:
        work = Path(name)
        (work / "docs" / "images").mkdir(parents=True)
        mse("sample", "embarrassment", "--seed", SEED, "--format", "svg", "-o", "docs/images/timeline.svg", cwd=work)
        mse("sample", "embarrassment", "--seed", SEED, "-o", "emb.json", cwd=work)
        mse("render", "emb.json", "-o", "docs/images/face.png", "--at", AT, cwd=work)
        animated = ("--animate", "emb", "--format", "html", "-o", "emb.html")
        mse("sample", "embarrassment", "--seed", SEED, *animated, cwd=work)
        screenshot(work / "emb.html", work / "docs" / "images" / "viewer.png")
        half_body(work / "docs" / "images" / "half-body.png")
        for picture in ("timeline.svg", "face.png", "viewer.png", "half-body.png"):
            shutil.copyfile(work / "docs" / "images" / picture, IMAGES / picture)
            print(f"wrote {IMAGES / picture}")


if __name__ == "__main__":
    main()
