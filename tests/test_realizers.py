"""Realizer profiles, mapping tables and lint against a realizer's libraries (no Java here;
tests/test_realizers_parsers.py runs the realizers' own parsers)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from lxml import etree

from mse.api import lint, load
from mse.diagnostics import MseError
from mse.export import ExportOptions, export_notes, render
from mse.export.lexemes import Lexeme
from mse.export.realizer_libraries import load_greta_libraries
from mse.export.realizers import (
    DEFAULT_REALIZER,
    GAZE_DIRECTIONS,
    REALIZERS,
    closest_name,
    lexeme_table,
    realize_greta,
    realizer_for,
)
from mse.resources import behaviour_sets_dir
from mse.timeline import Timeline, TimelineSignal

REPO = Path(__file__).resolve().parent.parent
BML = "{http://www.bml-initiative.org/bml/bml-1.0}"
GRETA = "{http://www.mindmakers.org/projects/BML}"

TINY = {
    "facelibrary.xml": '<facelibrary><expression class="faceexp" instance="small_joy"><action name="AU12"/>'
    '</expression><expression class="gaze" instance="peek"><action name="AU62"/></expression></facelibrary>',
    "HeadGestures.xml": '<HeadGestures><head id="Nod_Middle" lexeme="NOD"/><head id="Down" lexeme="Down"/>'
    "</HeadGestures>",
    "TorsoGestures.xml": '<TorsoGestures><torso id="BodyLean" lexeme="BodyLean"/></TorsoGestures>',
    "gestuary.xml": '<gestuary><gesture category="rest" id="akimbo"/><gesture category="emotion" id="panic_fear_7"/>'
    "</gestuary>",
}
SET = """<?xml version="1.0" encoding="UTF-8"?>
<expression name="probe">
  <signals>
    <signal id="smile" modality="face" lexeme="faceexp=smile"/>
    <signal id="grin" modality="face" lexeme="faceexp=small_jo"/>
    <signal id="nod" modality="head" lexeme="head=nod"/>
    <signal id="hand" modality="gesture" lexeme="emotion=panic_fear_signal_7"/>
    <signal id="hips" modality="gesture" lexeme="akimbo"/>
    <signal id="lean" modality="torso" lexeme="torso=lean_forward"/>
    <signal id="bow" modality="torso" lexeme="torso=bow"/>
    <signal id="down" modality="gaze" lexeme="gaze=look_down"/>
    <signal id="peek" modality="gaze" lexeme="gaze=peek"/>
    <signal id="stare" modality="gaze" lexeme="gaze=embarrassment_signal_3"/>
    <signal id="say" modality="speech" lexeme="speech=hello"/>
  </signals>
</expression>
"""


@pytest.fixture()
def tiny_library(tmp_path: Path) -> Path:
    folder = tmp_path / "lexicon"
    folder.mkdir()
    for name, text in TINY.items():
        (folder / name).write_text(text, encoding="utf-8")
    return folder


def timeline(*signals: tuple[str, str, str]) -> Timeline:
    return Timeline("t", 4.0, tuple(TimelineSignal(i, m, lx, 0.5, 2.0) for i, m, lx in signals), "hand-made", 1)


def test_profiles_and_defaults() -> None:
    assert REALIZERS == ("generic", "greta", "asap")
    assert DEFAULT_REALIZER == {"bml": "generic", "greta-bml": "greta"}
    assert realizer_for("bml", None) == "generic" and realizer_for("greta-bml", None) == "greta"
    assert realizer_for("bml", "greta") == "greta"
    for fmt, realizer in (("greta-bml", "asap"), ("greta-bml", "generic"), ("bml", "smartbody")):
        with pytest.raises(MseError) as error:
            realizer_for(fmt, realizer)
        assert error.value.diagnostics[0].code == "E130"


def test_cli_offers_every_profile() -> None:
    for command in ("sample", "export"):  # lint checks libraries, which only Greta has: --realizer greta
        done = subprocess.run(
            [sys.executable, "-m", "mse", command, "--help"], capture_output=True, text=True, check=True
        )
        assert "{" + ",".join(REALIZERS) + "}" in done.stdout.replace("\n", "")


def test_tables_are_well_formed() -> None:
    for realizer in REALIZERS:
        table = lexeme_table(realizer)
        assert set(table.entries) <= {"face", "head", "gaze", "gesture", "torso"}
        assert set(table.entries["gaze"]) >= {"look_down", "look_left", "look_at_listener"}
        for entry in table.entries["gaze"].values():
            assert entry.name in GAZE_DIRECTIONS


def test_greta_table_targets_exist_in_gretas_libraries(greta_dir: Path) -> None:
    libraries = load_greta_libraries(greta_dir)
    table = lexeme_table("greta")
    for modality in ("face", "head", "gesture", "torso"):
        for key, entry in table.entries[modality].items():
            realized = realize_greta(modality, Lexeme("", key), libraries)
            assert realized.known and realized.name == entry.name, (modality, key, entry)


def test_every_bundled_lexeme_resolves_in_greta(greta_dir: Path) -> None:
    found = lint([behaviour_sets_dir()], realizer="greta", library_dir=greta_dir, select=["W308"])
    assert found == []


def test_lint_reports_unresolvable_lexemes_at_the_signal(tmp_path: Path, tiny_library: Path) -> None:
    source = tmp_path / "probe.xml"
    source.write_text(SET, encoding="utf-8")
    found = {d.message.split("'")[1]: d for d in lint([source], realizer="greta", library_dir=tiny_library)}
    assert set(found) == {"grin", "hand", "bow", "stare"}, found
    assert found["grin"].span.line == 5 and found["grin"].span.path == str(source)
    assert "did you mean 'faceexp=small_joy'?" in found["grin"].message
    assert "did you mean 'emotion=panic_fear_7'?" in found["hand"].message
    assert "maps it to 'TrunkTiltingForwards'" in found["bow"].message and "leaves it out" in found["bow"].message
    assert "no direction" in found["stare"].message
    assert all(d.code == "W308" for d in found.values())


def test_lint_needs_a_library_of_a_known_realizer(tmp_path: Path) -> None:
    source = tmp_path / "probe.xml"
    source.write_text(SET, encoding="utf-8")
    cases = (("greta", None, "E130"), ("asap", tmp_path, "E130"), ("greta", tmp_path / "absent", "E100"))
    for realizer, library, code in cases:  # a missing option or a realizer without libraries; a missing folder
        (error,) = [d for d in lint([source], realizer=realizer, library_dir=library) if d.is_error]
        assert error.code == code


def test_lint_cli(tmp_path: Path, tiny_library: Path) -> None:
    source = tmp_path / "probe.xml"
    source.write_text(SET, encoding="utf-8")
    run = [sys.executable, "-m", "mse", "lint", "--no-deep", str(source)]
    done = subprocess.run(
        [*run, "--realizer", "greta", "--library-dir", str(tiny_library)], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    lines = [line for line in done.stdout.splitlines() if "W308" in line]
    assert len(lines) == 4 and re.match(rf"{re.escape(str(source))}:\d+:\d+: W308 signal", lines[0])
    strict = subprocess.run(
        [*run, "--strict", "--select", "W308", "--realizer", "greta", "--library-dir", str(tiny_library)],
        capture_output=True,
        text=True,
    )
    assert strict.returncode == 1
    missing = subprocess.run([*run, "--realizer", "greta"], capture_output=True, text=True)
    assert missing.returncode == 1 and "<arguments>: E130 --realizer greta needs --library-dir" in missing.stdout


def test_generic_and_asap_write_bml_core_that_asap_plays() -> None:
    t = timeline(("f", "face", "faceexp=smile"), ("h", "head", "head=nod"), ("p", "torso", "torso=bow"))
    for realizer in ("generic", "asap"):
        root = etree.fromstring(render(t, "bml", ExportOptions(realizer=realizer)).encode())
        assert root.find(f"{BML}faceLexeme").get("amount") == "1"  # type: ignore[union-attr]
        assert root.find(f"{BML}head").get("amount") == "1"  # type: ignore[union-attr]
        pose = root.find(f"{BML}posture/{BML}pose")
        assert pose is not None and pose.get("part") == "WHOLEBODY" and pose.get("lexeme") == "BOW"


def test_greta_profile_names_and_forms() -> None:
    t = timeline(
        ("f", "face", "faceexp=tensed_smile"),
        ("h", "head", "head=head_forward"),
        ("g", "gesture", "gesture=hands_on_hips"),
        ("b", "torso", "torso=bow"),
        ("z", "gaze", "gaze=look_away"),
        ("s", "speech", "speech=hello there"),
    )
    for fmt, ns in (("greta-bml", GRETA), ("bml", BML)):
        root = etree.fromstring(render(t, fmt, ExportOptions(realizer="greta")).encode())
        assert root.find(f"{ns}faceLexeme[@id='f']").get("lexeme") == "politeness"  # type: ignore[union-attr]
        assert root.findtext(f"{ns}head[@id='h']/{ns}description/{ns}reference") == "Forward"
        assert root.findtext(f"{ns}gesture[@id='g']/{ns}description/{ns}reference") == "emotion=anger_signal_5"
        assert root.find(f"{ns}torso[@id='b']").get("lexeme") == "TrunkTiltingForwards"  # type: ignore[union-attr]
        assert root.find(f"{ns}gaze[@id='z']").get("offsetDirection") == "LEFT"  # type: ignore[union-attr]
        speech = root.find(f"{ns}speech[@id='s']")
        assert speech is not None and speech.text == "hello there" and len(speech) == 0  # plain text, no <text>
    assert export_notes(t, "greta-bml") == []


def test_greta_profile_leaves_out_torsos_greta_lacks(tiny_library: Path) -> None:
    t = timeline(("a", "torso", "embarrassment_signal_11"), ("b", "torso", "torso=BodyLean"), ("c", "torso", "bow"))
    text = render(t, "greta-bml")
    root = etree.fromstring(text.encode())
    # Without libraries only names mse's table knows are written (BodyLean is one of its targets).
    assert [e.get("id") for e in root.iter(f"{GRETA}torso")] == ["b", "c"]
    (note,) = export_notes(t, "greta-bml", where="emb.xml")
    assert note.code == "W601" and note.render().startswith("emb.xml: W601 torso signal 'a'")
    assert "a: torso signal 'a' (embarrassment_signal_11) left out" in text
    # With a library folder, the folder decides: it has BodyLean only.
    options = ExportOptions(library_dir=tiny_library)
    root = etree.fromstring(render(t, "greta-bml", options).encode())
    assert [e.get("id") for e in root.iter(f"{GRETA}torso")] == ["b"]
    assert [
        n.message.split("'")[1]
        for n in export_notes(t, "bml", ExportOptions(realizer="greta", library_dir=tiny_library))
    ] == ["a", "c"]
    # the generic profile writes every posture, saying which lexemes BML 1.0 leaves to the realizer
    assert {d.code for d in export_notes(t, "bml")} <= {"W603"}


def test_greta_profile_uses_the_library_for_gaze_and_bare_gestures(tiny_library: Path) -> None:
    t = timeline(("z", "gaze", "gaze=peek"), ("g", "gesture", "akimbo"))
    root = etree.fromstring(render(t, "greta-bml", ExportOptions(library_dir=tiny_library)).encode())
    assert root.find(f"{GRETA}gaze").get("offsetDirection") == "RIGHT"  # type: ignore[union-attr]  # AU62
    assert root.findtext(f"{GRETA}gesture/{GRETA}description/{GRETA}reference") == "rest=akimbo"


def test_export_cli_prints_w601(tmp_path: Path) -> None:
    source = tmp_path / "t.json"
    source.write_text(timeline(("a", "torso", "embarrassment_signal_11")).dumps(), encoding="utf-8")
    done = subprocess.run(
        [sys.executable, "-m", "mse", "export", str(source), "--format", "greta-bml"], capture_output=True, text=True
    )
    assert done.returncode == 0 and f"{source}: W601 torso signal 'a'" in done.stderr
    bad = subprocess.run(
        [sys.executable, "-m", "mse", "export", str(source), "--format", "greta-bml", "--realizer", "asap"],
        capture_output=True,
        text=True,
    )
    assert bad.returncode == 1 and "<arguments>: E130 --format greta-bml" in bad.stderr and not bad.stdout


def test_did_you_mean_stays_within_a_family() -> None:
    assert closest_name("emotion=panic_fear_signal_7", ["emotion=panic_fear_7", "emotion=anger_signal_7"]) == (
        "emotion=panic_fear_7"
    )
    assert closest_name("regret_signal_1", ["relief_signal_1"]) is None
    assert closest_name("smal_joy", ["small_joy", "joy"]) == "small_joy"


def test_docs_list_every_greta_mapping() -> None:
    docs = (REPO / "docs" / "realizers.md").read_text(encoding="utf-8")
    for modality, rows in lexeme_table("greta").entries.items():
        for key, entry in rows.items():
            shown = f"`{entry.name}`" if entry.name else "straight"
            assert re.search(rf"\| `{re.escape(key)}` \| {re.escape(shown)}", docs), (modality, key)


def test_bundled_sets_sample_into_greta_bml_without_notes() -> None:
    from mse.resources import bundled_names
    from mse.sampling import sample

    for name in bundled_names():
        t = sample(load(name), 10.0, seed=5)
        assert isinstance(t, Timeline) and export_notes(t, "greta-bml") == []


def test_greta_profile_never_writes_an_empty_reference() -> None:
    """An empty ``<reference>`` makes Greta's BML reader throw: nameless signals are left out."""
    t = timeline(("h", "head", "head="), ("g", "gesture", "gesture="), ("f", "face", ""), ("z", "gaze", ""))
    text = render(t, "greta-bml")
    assert "<reference></reference>" not in text and "<reference/>" not in text
    assert sorted(n.message.split("'")[1] for n in export_notes(t, "greta-bml")) == ["f", "g", "h"]
    assert etree.fromstring(text.encode()).find(f"{GRETA}gaze") is not None  # a gaze needs no name
