"""FML-APML in: mse reads Greta's real files as Greta's own reader does (``$MSE_SHARED/fml/parse``),
maps emotions onto dialogue events and reports everything else."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest

from mse.diagnostics import MseError
from mse.dialogue.inputs import read_input
from mse.dialogue.inputs.common import load_emotion_names
from mse.dialogue.inputs.fml import read_fml, read_fml_document


def _examples(shared: Path) -> list[Path]:
    files = sorted((shared / "fml" / "examples").glob("*.xml"))
    if not files:
        pytest.skip(f"no FML-APML examples in {shared / 'fml' / 'examples'}")
    return files


@pytest.fixture(scope="module")
def greta_reading(shared_dir: Path) -> dict[str, list[dict[str, Any]]]:
    """Greta's own reading of every example (one JVM): file -> its JSON lines."""
    if shutil.which("java") is None:
        pytest.skip("no Java runtime on PATH (CI installs openjdk-17-jre-headless)")
    files = _examples(shared_dir)
    done = subprocess.run(
        ["bash", str(shared_dir / "fml" / "parse"), *map(str, files)],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    lines: dict[str, list[dict[str, Any]]] = {}
    for line in done.stdout.splitlines():
        if line.startswith("{"):
            entry = json.loads(line)
            lines.setdefault(str(Path(entry["file"]).resolve()), []).append(entry)
    assert len(lines) == len(files), done.stderr[-2000:]
    return lines


def _greta_text(text: str) -> str:
    # Greta builds the text by appending to a null String when the speech has no text attribute
    # (Speech.getOriginalText): its reading starts with "null".
    return " ".join(text.removeprefix("null").split())


def test_every_real_file_reads_as_greta_reads_it(
    shared_dir: Path, greta_reading: dict[str, list[dict[str, Any]]]
) -> None:
    for path in _examples(shared_dir):
        greta = greta_reading[str(path.resolve())]
        parsed = greta[0]
        assert parsed["event"] == "parsed", parsed
        document = read_fml_document(path)
        assert document.composition == parsed["composition"], path.name
        speeches = [g for g in greta if g.get("class") == "PseudoIntentionSpeech"]
        assert [(s.id, list(s.marks), s.text) for s in document.speeches] == [
            (g["id"], g["time_markers"], _greta_text(g["text"])) for g in speeches
        ], path.name
        intentions = [g for g in greta[1:] if g.get("class", "").startswith(("Basic", "Emotion", "Certainty", "Laugh"))]
        mine = [
            {
                "name": f.name,
                "id": f.id,
                "type": f.type,
                "start": [f.start.greta()] if f.start else [],
                "end": [f.end.greta()] if f.end else [],
                "importance": f.importance,
                **({"intensity": f.intensity} if f.intensity is not None else {}),
                **({"emotion": f.type, "regulation": f.regulation} if f.name == "emotion" else {}),
            }
            for f in document.functions
        ]
        theirs = [
            {
                k: g[k]
                for k in ("name", "id", "type", "start", "end", "importance", "intensity", "emotion", "regulation")
                if k in g
            }
            for g in intentions
        ]
        assert mine == theirs, path.name


def test_every_function_is_played_or_reported(shared_dir: Path) -> None:
    """Nothing is dropped without a word: each <fml> function is an emotion event or a warning
    at its own line, and each emotion event starts at the time of the mark it names."""
    for path in _examples(shared_dir):
        document = read_fml_document(path)
        reading = read_fml(path)
        warned = {w.span.line for w in reading.warnings}
        played = {e.span.line: e for e in reading.events if "emotion" in e.event}
        for function in document.functions:
            line = function.span.line
            assert line in played or line in warned, f"{path.name}:{line} {function.name} neither played nor reported"
            moved = {w.span.line for w in reading.warnings if w.code == "W524"}  # to the speech's start
            if line in played and function.start is not None and line not in moved:
                assert played[line].t == pytest.approx(document.time_of(function.start))
                if function.end is not None:
                    assert played[line].event["until"] == pytest.approx(document.time_of(function.end))


def test_example_mapping(shared_dir: Path) -> None:
    reading = read_fml(shared_dir / "fml" / "examples" / "step1_3.xml")
    kinds = [next(k for k in ("emotion", "say", "end") if k in e.event) for e in reading.events]
    assert kinds == ["emotion", "say", "end"]
    relief = reading.events[0]
    assert relief.event["emotion"] == "relief" and relief.span.render().endswith("step1_3.xml:31:1")
    codes = {w.code for w in reading.warnings}
    assert {"W520", "W521", "W522", "W524"} <= codes
    # Greta's emotion types map through the shipped table: joyStrong -> cheerfulness.
    friendly = read_fml(shared_dir / "fml" / "examples" / "verve_fml_friendly_outgroup.xml")
    assert [dict(e.event) for e in friendly.events] == [
        {"t": 0.0, "emotion": "cheerfulness", "intensity": 1.0, "until": 5.0},
        {"t": 5.0, "end": True},
    ]
    assert read_input(shared_dir / "fml" / "examples" / "name.xml").format == "fml-apml"


def _write(tmp_path: Path, body: str, name: str = "x.xml") -> Path:
    path = tmp_path / name
    path.write_text(f'<?xml version="1.0"?>\n<fml-apml>\n{body}\n</fml-apml>\n', encoding="utf-8")
    return path


SPEECH = """<bml><speech id="s1" start="1.0"><tm id="tm1" time="1.0"/>I can't <tm id="tm2" time="1.6"/>believe
<tm id="tm3" time="2.0"/>it<tm id="tm4" time="2.3"/>
<pitchaccent id="pa1" start="s1:tm2" end="s1:tm3"/></speech></bml>"""


def test_mark_times_pin_words_and_pitch_accents_stress(tmp_path: Path) -> None:
    path = _write(
        tmp_path,
        SPEECH
        + """<fml>
<emotion id="e1" type="anger" start="s1:tm1" end="s1:tm3+0.1" intensity="0.8"/>
<emotion id="e2" type="relief" start="e1:end"/></fml>""",
    )
    reading = read_fml(path)
    events = [dict(e.event) for e in reading.events]
    assert events[0] == {"t": 1.0, "emotion": "anger", "intensity": 0.8, "until": 2.1}
    say = events[1]
    assert say["say"] == "I can't believe it" and say["stress"] == ["believe"]
    assert say["words"][0][1] == 1.0 and say["words"][2][1] == 1.6 and say["words"][3][1] == 2.0
    assert say["words"][-1][2] == pytest.approx(2.3)
    assert events[2] == {"t": 2.1, "emotion": "relief", "intensity": 1.0}  # no end: until the input ends
    assert events[-1] == {"t": 2.3, "end": True}
    assert not [w for w in reading.warnings if w.code == "W524"]  # the marks gave the times


def test_overlapping_emotions_are_cut_and_reported(tmp_path: Path) -> None:
    path = _write(
        tmp_path,
        """<fml>
<emotion id="a" type="anger" start="0" end="5"/>
<emotion id="b" type="relief" start="2" end="3"/></fml>""",
    )
    reading = read_fml(path)
    assert [dict(e.event) for e in reading.events] == [
        {"t": 0.0, "emotion": "anger", "intensity": 1.0, "until": 2.0},
        {"t": 2.0, "emotion": "relief", "intensity": 1.0, "until": 3.0},
        {"t": 3.0, "emotion": "anger", "intensity": 1.0, "until": 5.0},
        {"t": 5.0, "end": True},
    ]
    assert [w.span.line for w in reading.warnings if w.code == "W523"] == [4]


def test_emotion_names_table_is_overridable(tmp_path: Path) -> None:
    table = tmp_path / "names.toml"
    table.write_text('[fml-apml]\nhate = "anger"\n', encoding="utf-8")
    path = _write(tmp_path, '<fml><emotion id="e" type="hate" start="0" end="1"/></fml>')
    assert not [e for e in read_fml(path).events if "emotion" in e.event]
    reading = read_fml(path, names=load_emotion_names([table]))
    assert reading.events[0].event["emotion"] == "anger"


def test_unknown_emotion_gets_did_you_mean(tmp_path: Path) -> None:
    path = _write(tmp_path, '<fml><emotion id="e" type="angr" start="0" end="1"/></fml>')
    (warning,) = [w for w in read_fml(path).warnings if w.code == "W522"]
    assert "did you mean 'anger'" in warning.message and warning.span.line == 3


@pytest.mark.parametrize(
    ("body", "code", "line"),
    [
        ('<fml><emotion id="e" type="anger" start="s1:tm9" end="1"/></fml>', "E151", 3),
        ('<fml><emotion id="e" type="anger" start="0" end="abc+"/></fml>', "E152", 3),
        ('<fml><emotion id="e" type="anger" start="0" end="1" intensity="3"/></fml>', "E152", 3),
        ('<fml><emotion id="e" type="anger" start="2" end="1"/></fml>', "E152", 3),
        ('<fml><emotion id="e" type="anger" end="1"/></fml>', "E150", 3),
        ('<fml><emotion id="e" type="anger" start="-1"/></fml>', "E152", 3),
    ],
)
def test_bad_input_is_an_error_with_its_place(tmp_path: Path, body: str, code: str, line: int) -> None:
    with pytest.raises(MseError) as caught:
        read_fml(_write(tmp_path, body))
    (diagnostic,) = caught.value.diagnostics
    assert (diagnostic.code, diagnostic.span.line) == (code, line), diagnostic.render()
    assert diagnostic.span.col > 0


def test_unsafe_or_broken_xml_is_refused(tmp_path: Path) -> None:
    bomb = tmp_path / "bomb.xml"
    bomb.write_text('<?xml version="1.0"?>\n<!DOCTYPE fml-apml [<!ENTITY a "aaaa">]>\n<fml-apml>&a;</fml-apml>\n')
    broken = tmp_path / "broken.xml"
    broken.write_text("<fml-apml><fml>\n")
    wrong = tmp_path / "wrong.xml"
    wrong.write_text("<bml/>")
    for path, code in ((bomb, "E103"), (broken, "E101"), (wrong, "E150"), (tmp_path / "missing.xml", "E100")):
        with pytest.raises(MseError) as caught:
            read_fml(path)
        assert caught.value.diagnostics[0].code == code, caught.value


def test_script_events_for_the_session(shared_dir: Path) -> None:
    """The events are a dialogue script's (parse_events): speech before the first emotion is
    spoken with it (W524); a file with no playable emotion is an error that shows why."""
    from mse.dialogue import EmotionEvent, EndEvent, SayEvent
    from mse.dialogue.inputs import read_dialogue_input

    events, warnings = read_dialogue_input(shared_dir / "fml" / "examples" / "2-SeeYou.xml")
    assert [type(e) for e in events] == [EmotionEvent, SayEvent, EndEvent]
    assert events[0].t == 0.0 and isinstance(events[0], EmotionEvent) and events[0].emotion == "cheerfulness"
    assert any(w.code == "W524" and w.span.line == 36 for w in warnings)
    with pytest.raises(MseError) as caught:
        read_dialogue_input(shared_dir / "fml" / "examples" / "unityShortSpeech_Obadiah_1.xml")
    codes = [d.code for d in caught.value.diagnostics]
    assert "E150" in codes and "W522" in codes  # envy has no set: that is why nothing plays


@pytest.mark.parametrize(
    ("body", "code"),
    [
        ('<bml><speech id="s1"><tm id="a" time="x"/>hi</speech></bml>', "E152"),
        ('<bml><speech id="s1">hi</speech><speech id="s1">ho</speech></bml>', "E150"),
        ("<bml><speech>hi</speech></bml>", "E150"),
        (
            '<fml><emotion id="a" type="anger" start="b:end" end="5"/>'
            '<emotion id="b" type="anger" start="a:start"/></fml>',
            "E151",
        ),
        ('<fml><emotion id="a" type="anger" start="0" end="s1:tm1 + x"/></fml>', "E152"),
    ],
)
def test_more_bad_input(tmp_path: Path, body: str, code: str) -> None:
    with pytest.raises(MseError) as caught:
        read_fml(_write(tmp_path, body))
    assert caught.value.diagnostics[0].code == code, caught.value


def test_odd_but_readable_input_is_reported(tmp_path: Path) -> None:
    path = _write(
        tmp_path,
        """<bml><speech id="s1" start="0.5">Hello <tm id="t1"/>there
<pitchaccent id="p" start="s1:nowhere" end="s1:t1"/><boundary id="b" start="s1:t1" type="LL"/></speech>
<gesture id="g" lexeme="BEAT"/></bml>
<fml><emotion type="anger" start="0"/><emotion id="e" type="anger" start="s1:start" end="s1:end"
 regulation="fake"/><performative id="p1" type="inform" start="0"/></fml><extra/>""",
    )
    reading = read_fml(path)
    codes = sorted(w.code for w in reading.warnings)
    assert codes.count("W520") == 5 and "W527" in codes and "W521" in codes, codes
    emotion, say, end = (dict(e.event) for e in reading.events)
    assert emotion["t"] == 0.5 and say["t"] == 0.5 and end["t"] == emotion["until"] == say["words"][-1][2]
