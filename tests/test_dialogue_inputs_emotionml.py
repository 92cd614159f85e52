"""EmotionML in: emotions with times become dialogue events; the reference checker
(``$MSE_SHARED/emotionml/check``) agrees with mse on what is invalid, and the inputs written here
are valid EmotionML for it."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest
from lxml import etree

from mse.diagnostics import MseError
from mse.dialogue.inputs import read_input
from mse.dialogue.inputs.common import load_emotion_names
from mse.dialogue.inputs.emotionml import NAMESPACE, read_emotionml, vocabulary_names

W3C = "http://www.w3.org/TR/emotion-voc/xml#"


def _check(shared: Path, files: list[Path]) -> dict[str, str]:
    """The checker's verdict per file: "VALID" or its INVALID line."""
    if shutil.which("java") is None:
        pytest.skip("no Java runtime on PATH (CI installs openjdk-17-jre-headless)")
    done = subprocess.run(
        ["bash", str(shared / "emotionml" / "check"), *map(str, files)],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    verdicts: dict[str, str] = {}
    current = ""
    for line in done.stdout.splitlines():
        if line.startswith("=== FILE "):
            current = line.removeprefix("=== FILE ")
        elif current and (line == "VALID" or line.startswith("INVALID")):
            verdicts[current] = line
    assert len(verdicts) == len(files), done.stdout + done.stderr
    return verdicts


def _document(body: str, sets: str = f'category-set="{W3C}big6"') -> str:
    return f'<?xml version="1.0"?>\n<emotionml version="1.0" xmlns="{NAMESPACE}" {sets}>\n{body}\n</emotionml>\n'


DIALOGUE = _document(
    f"""  <emotion start="1268647200000" end="1268647203700" dimension-set="{W3C}intensity-dimension">
    <category name="anger"/>
    <dimension name="intensity" value="0.8"/>
  </emotion>
  <emotion start="1268647203700" end="1268647208700">
    <category name="happiness" value="0.6"/>
    <category name="sadness" value="0.2"/>
  </emotion>
  <emotion start="1268647210000" expressed-through="face">
    <category name="fear"/>
  </emotion>"""
)
RELATIVE = _document(
    """  <emotion offset-to-start="500" duration="2000" time-ref-uri="#utterance1">
    <category name="anger" value="0.5"/>
  </emotion>
  <emotion offset-to-start="2500" time-ref-uri="#utterance1">
    <category name="fear"/>
  </emotion>"""
)
MIXED = _document(
    """  <emotion start="0" end="1000"><category name="anger"/></emotion>
  <emotion offset-to-start="500" time-ref-uri="#u"><category name="fear"/></emotion>"""
)


@pytest.fixture()
def written(tmp_path: Path) -> dict[str, Path]:
    files = {}
    for name, text in (("dialogue", DIALOGUE), ("relative", RELATIVE), ("mixed", MIXED)):
        files[name] = tmp_path / f"{name}.emotionml"
        files[name].write_text(text, encoding="utf-8")
    return files


@pytest.mark.slow
def test_inputs_written_here_are_valid_emotionml(shared_dir: Path, written: dict[str, Path]) -> None:
    verdicts = _check(shared_dir, list(written.values()))
    assert set(verdicts.values()) == {"VALID"}, verdicts


def test_clock_times_intensity_and_blends(written: dict[str, Path]) -> None:
    reading = read_input(written["dialogue"])
    assert reading.format == "emotionml"
    assert [dict(e.event) for e in reading.events] == [
        {"t": 0.0, "emotion": "anger", "intensity": 0.8, "until": 3.7},
        {"t": 3.7, "emotion": "cheerfulness", "intensity": 0.6, "until": 8.7},
        {"t": 10.0, "emotion": "panic_fear", "intensity": 1.0},
    ]  # no end: the last emotion has none, the planner gives it its horizon
    assert [e.span.line for e in reading.events[:3]] == [3, 7, 11]
    codes = {(w.code, w.span.line) for w in reading.warnings}
    assert ("W525", 9) in codes  # sadness, the weaker category, is reported
    assert ("W521", 11) in codes  # expressed-through
    assert ("W524", 2) in codes  # clock times counted from the first start


def test_relative_times(written: dict[str, Path]) -> None:
    reading = read_emotionml(written["relative"])
    assert [dict(e.event) for e in reading.events] == [
        {"t": 0.5, "emotion": "anger", "intensity": 0.5, "until": 2.5},
        {"t": 2.5, "emotion": "panic_fear", "intensity": 1.0},
    ]
    with pytest.raises(MseError) as caught:
        read_emotionml(written["mixed"])
    assert caught.value.diagnostics[0].code == "E151"


@pytest.mark.slow
def test_checker_and_mse_agree_on_the_kit_documents(shared_dir: Path) -> None:
    """Every document of the checker's kit: the checker rejects it exactly when mse does
    (valid ones may still play nothing: their emotions have no time, and that is reported)."""
    folder = shared_dir / "emotionml"
    files = sorted((folder / "tests").glob("*")) + sorted((folder / "samples").glob("*.emotionml"))
    verdicts = _check(shared_dir, files)
    for path in files:
        try:
            reading = read_input(path)
            mine = "VALID"
        except MseError as error:
            mine = "INVALID " + str(error)
            reading = None
        assert (verdicts[str(path)] == "VALID") == (mine == "VALID"), (path.name, verdicts[str(path)], mine)
        if reading is not None:
            emotions = len(etree.parse(str(path)).getroot().findall(f"{{{NAMESPACE}}}emotion"))
            placed = len([e for e in reading.events if "emotion" in e.event])
            reported = len({w.span.line for w in reading.warnings if w.code in ("W522", "W526")})
            assert placed + reported >= emotions, path.name


def test_name_table_lists_every_w3c_category(shared_dir: Path) -> None:
    vocabularies = shared_dir / "emotionml" / "resources" / "emotionml" / "emotion-voc.emotionml"
    root = etree.parse(str(vocabularies)).getroot()
    w3c = {
        W3C + v.get("id", ""): {i.get("name") for i in v}
        for v in root.iter(f"{{{NAMESPACE}}}vocabulary")
        if v.get("type") == "category"
    }
    assert vocabulary_names(load_emotion_names()) == w3c
    # Every set the table names is bundled.
    from mse.resources import bundled_names

    targets = {t for table in load_emotion_names().tables.values() for t in table.values() if t}
    assert targets - {"intensity"} <= set(bundled_names())


@pytest.mark.parametrize(
    ("body", "code", "where"),
    [
        ('<emotion start="0.5"><category name="anger"/></emotion>', "E152", (3, 10)),
        ('<emotion start="0" end="0"><category name="anger"/></emotion>', "E152", (3, 1)),
        ('<emotion start="0"><category name="joy"/></emotion>', "E150", (3, 30)),
        ('<emotion start="0"><category name="anger" value="2"/></emotion>', "E152", (3, 43)),
        ('<emotion start="0" category-set="#mine"><category name="anger"/></emotion>', "E150", (3, 1)),
    ],
)
def test_bad_input_is_an_error_with_its_place(tmp_path: Path, body: str, code: str, where: tuple[int, int]) -> None:
    path = tmp_path / "bad.emotionml"
    path.write_text(_document(body), encoding="utf-8")
    with pytest.raises(MseError) as caught:
        read_emotionml(path)
    (diagnostic,) = caught.value.diagnostics
    assert (diagnostic.code, diagnostic.span.line, diagnostic.span.col) == (code, *where), diagnostic.render()


def test_local_vocabulary_and_wrong_root(tmp_path: Path) -> None:
    path = tmp_path / "local.emotionml"
    path.write_text(
        _document(
            '<vocabulary type="category" id="mine"><item name="rage"/></vocabulary>\n'
            '<emotion start="0" end="10" category-set="#mine"><category name="rage"/></emotion>'
        ),
        encoding="utf-8",
    )
    table = tmp_path / "names.toml"
    table.write_text('["#mine"]\nrage = "anger"\n', encoding="utf-8")
    reading = read_emotionml(path, names=load_emotion_names([table]))
    assert reading.events[0].event["emotion"] == "anger"
    wrong = tmp_path / "wrong.xml"
    wrong.write_text('<emotionml xmlns="urn:other" version="1.0"/>')
    with pytest.raises(MseError, match=re.escape(NAMESPACE)):
        read_emotionml(wrong)


def test_read_events_tells_scripts_and_markup_apart(tmp_path: Path, written: dict[str, Path]) -> None:
    from mse.dialogue import plan_script
    from mse.dialogue.inputs import read_events

    script = tmp_path / "talk.jsonl"
    script.write_text('{"t": 0, "emotion": "anger", "until": 2}\n{"t": 2, "end": true}\n', encoding="utf-8")
    events, notes = read_events(script)
    assert len(events) == 2 and notes == []
    events, notes = read_events(written["dialogue"])
    assert len(events) == 3 and notes
    timeline = plan_script(events, seed=1)
    assert [e["emotion"] for e in timeline.episodes if e["start"] in (0.0, 3.7, 10.0)] == [
        "anger",
        "cheerfulness",
        "panic_fear",
    ]
