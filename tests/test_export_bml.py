"""BML 1.0 and Greta BML exporters: schema validity, mappings, ids, face library."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from lxml import etree

from mse.diagnostics import MseError
from mse.export import FORMAT_NAMES, ExportOptions, render
from mse.export.lexemes import format_seconds, sanitize_id, unique_ids
from mse.export.realizer_libraries import load_face_library
from mse.timeline import Timeline, TimelineSignal, loads_many

FIXTURE = Path(__file__).resolve().parent / "fixtures" / "export" / "embarrassment_timeline.json"
BML = "{http://www.bml-initiative.org/bml/bml-1.0}"
GRETA = "{http://www.mindmakers.org/projects/BML}"
EXT = "{http://www.bml-initiative.org/bml/coreextensions-1.0}"
ID_PATTERN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")

TINY_LIBRARY = """<?xml version="1.0"?>
<facelibrary>
  <expression class="faceexp" instance="shy_smile">
    <action intensity="0.7" name="AU12"/><action intensity="0.4" name="AU6"/>
  </expression>
  <expression class="gaze" instance="look_down"><action intensity="0.5" name="AU64"/></expression>
</facelibrary>
"""


@pytest.fixture(scope="module")
def embarrassment() -> Timeline:
    return loads_many(FIXTURE.read_text(encoding="utf-8"), path=str(FIXTURE))[0]


@pytest.fixture(scope="module")
def bml_schema(shared_dir: Path) -> etree.XMLSchema:
    """The shared BML 1.0 XSD with one correction: ``part`` on ``<pose>``, which BML 1.0 requires
    (AsapRealizer rejects a pose without it) and the XSD forbids (docs/realizers.md)."""
    xsd = shared_dir / "bml" / "bml-1.0.xsd"
    if not xsd.is_file():
        pytest.skip(f"BML 1.0 schema not found in {shared_dir}")
    tree = etree.parse(str(xsd))
    xs = "{http://www.w3.org/2001/XMLSchema}"
    (pose_type,) = [t for t in tree.iter(f"{xs}complexType") if t.get("name") == "poseType"]
    assert not [a for a in pose_type.iter(f"{xs}attribute") if a.get("name") == "part"], "the XSD now has part"
    etree.SubElement(pose_type, f"{xs}attribute", name="part", type="closedSetItem")
    return etree.XMLSchema(tree)


def generic_timeline() -> Timeline:
    signals = (
        TimelineSignal("smile-1", "face", "faceexp=smile", 0.0, 1.5),
        TimelineSignal("head down", "head", "head=head_down", 0.5, 2.0),
        TimelineSignal("gaze.down", "gaze", "gaze=look_down_left", 1.0, 2.25),
        TimelineSignal("9wave", "gesture", "beat=beat_right", 1.0, 1.8),
        TimelineSignal("lean", "torso", "torso=lean_forward", 2.0, 3.0),
        TimelineSignal("hello", "speech", "speech=hello there", 2.0, 3.0),
        TimelineSignal("blush", "", "skin=blush", 2.5, 3.0),
    )
    return Timeline("relief test", 3.0, signals, solver="cp-sat", seed=3)


def parse(text: str) -> etree._Element:
    return etree.fromstring(text.encode("utf-8"))


def test_format_names() -> None:
    assert FORMAT_NAMES == ("bml", "greta-bml", "svg", "html", "eaf", "openface", "arkit", "arkit-json")


@pytest.mark.parametrize(
    "options",
    [
        ExportOptions(),
        ExportOptions(bml_constraints=True),
        ExportOptions(character_id="Robot-1", composition="replace"),
    ],
)
def test_default_bml_validates(embarrassment: Timeline, bml_schema: etree.XMLSchema, options: ExportOptions) -> None:
    for timeline in (embarrassment, generic_timeline()):
        document = parse(render(timeline, "bml", options))
        assert bml_schema.validate(document), bml_schema.error_log


def test_face_library_output_validates(embarrassment: Timeline, bml_schema: etree.XMLSchema, greta_dir: Path) -> None:
    options = ExportOptions(face_library=greta_dir / "facelibrary.xml")
    document = parse(render(embarrassment, "bml", options))
    assert bml_schema.validate(document), bml_schema.error_log
    # embarrassment_signal_6 is AU12 + AU6 in Greta's library: a smile.
    face = document.find(f"{BML}faceLexeme[@id='s_6']")
    assert face is not None and face.get("lexeme") == "RAISE_MOUTH_CORNERS"


def test_one_behaviour_per_occurrence_with_absolute_times(embarrassment: Timeline) -> None:
    root = parse(render(embarrassment, "bml"))
    assert root.tag == f"{BML}bml"
    assert root.get("characterId") == "Agent" and root.get("composition") == "MERGE"
    assert not root.get("id", "").startswith(tuple("0123456789")) and root.get("id") != "bml"
    behaviours = [child for child in root if isinstance(child.tag, str)]
    assert len(behaviours) == len(embarrassment.signals)
    for child, signal in zip(behaviours, embarrassment.signals, strict=True):
        assert ID_PATTERN.fullmatch(child.get("id", ""))
        assert float(child.get("start", "nan")) == pytest.approx(signal.start)
        assert float(child.get("end", "nan")) == pytest.approx(signal.stop)
    ids = [child.get("id") for child in behaviours]
    assert len(set(ids)) == len(ids)  # the repeated signal 4 gets a second id


def test_generic_lexemes_map_to_bml_values() -> None:
    root = parse(render(generic_timeline(), "bml"))
    by_id = {child.get("id"): child for child in root if isinstance(child.tag, str)}
    assert by_id["smile_1"].tag == f"{BML}faceLexeme"
    assert by_id["smile_1"].get("lexeme") == "RAISE_MOUTH_CORNERS"
    assert by_id["head_down"].tag == f"{BML}head" and by_id["head_down"].get("lexeme") == "DOWN"
    gaze = by_id["gaze_down"]
    assert gaze.get("offsetDirection") == "DOWNLEFT" and gaze.get("target") == "camera"
    assert by_id["s_9wave"].tag == f"{BML}gesture"
    assert by_id["s_9wave"].get("lexeme") == "BEAT_RIGHT"
    posture = by_id["lean"]
    assert posture.tag == f"{BML}posture"
    assert posture.find(f"{BML}pose").get("lexeme") == "LEAN_FORWARD"  # type: ignore[union-attr]
    speech = by_id["hello"]
    assert speech.find(f"{BML}text").text == "hello there"  # type: ignore[union-attr]
    # A modality BML 1.0 cannot express is left as a comment, not silently dropped.
    assert "blush" in render(generic_timeline(), "bml").split("-->")[-2]


def test_extensions_emit_face_facs_per_action_unit(tmp_path: Path) -> None:
    library = tmp_path / "faces.xml"
    library.write_text(TINY_LIBRARY, encoding="utf-8")
    timeline = Timeline("shy", 2.0, (TimelineSignal("s", "face", "faceexp=shy_smile", 0.0, 2.0),), "greedy", 1)
    root = parse(render(timeline, "bml", ExportOptions(face_library=library, bml_extensions=True)))
    facs = root.findall(f"{EXT}faceFacs")
    assert [(f.get("au"), f.get("amount")) for f in facs] == [("12", "0.7"), ("6", "0.4")]
    assert len({f.get("id") for f in facs}) == 2
    plain = parse(render(timeline, "bml", ExportOptions(face_library=library)))
    assert plain.find(f"{BML}faceLexeme").get("lexeme") == "RAISE_MOUTH_CORNERS"  # type: ignore[union-attr]
    assert plain.find(f"{BML}faceLexeme").get("amount") == "0.7"  # type: ignore[union-attr]


def test_constraints_are_metadata_for_shared_sync_points(bml_schema: etree.XMLSchema) -> None:
    root = parse(render(generic_timeline(), "bml", ExportOptions(bml_constraints=True)))
    refs = [sorted(s.get("ref", "") for s in c.iter(f"{BML}sync")) for c in root.iter(f"{BML}constraint")]
    assert ["gaze_down:start", "s_9wave:start"] in refs
    assert bml_schema.validate(root)


def test_greta_dialect(embarrassment: Timeline) -> None:
    text = render(embarrassment, "greta-bml", ExportOptions(character_id="Greta"))
    root = parse(text)
    assert root.tag == f"{GRETA}bml"
    assert root.get("composition") == "blend" and root.get("characterId") == "Greta"
    # faceLexeme keeps the behaviour id in Greta (<face><lexeme/></face> would become s_6embarrassment_signal_6)
    face = root.find(f"{GRETA}faceLexeme[@id='s_6']")
    assert face is not None and face.get("lexeme") == "embarrassment_signal_6" and face.get("amount") == "1"
    gesture = root.find(f"{GRETA}gesture[@id='s_10']")
    assert gesture is not None and gesture.get("lexeme") == "embarrassment_signal_10"
    assert gesture.findtext(f"{GRETA}description/{GRETA}reference") == "emotion=embarrassment_signal_10"
    head = root.find(f"{GRETA}head[@id='s_1']")
    assert head is not None and head.get("lexeme") == "embarrassment_signal_1"
    assert head.findtext(f"{GRETA}description/{GRETA}reference") == "embarrassment_signal_1"
    # Greta's own torso name is not in its TorsoGestures: left out, never a block that throws.
    assert root.find(f"{GRETA}torso") is None
    assert "s_11: torso signal '11' (embarrassment_signal_11) left out" in text
    behaviours = [child for child in root if isinstance(child.tag, str)]
    assert len(behaviours) == len(embarrassment.signals) - 1


def test_greta_gaze_direction_from_face_library(tmp_path: Path) -> None:
    library = tmp_path / "faces.xml"
    library.write_text(TINY_LIBRARY, encoding="utf-8")
    timeline = Timeline("g", 1.0, (TimelineSignal("g", "gaze", "gaze=look_down", 0.0, 1.0),))
    root = parse(render(timeline, "greta-bml", ExportOptions(face_library=library)))
    assert root.find(f"{GRETA}gaze").get("offsetDirection") == "DOWN"  # type: ignore[union-attr]


def test_face_library_errors(tmp_path: Path) -> None:
    timeline = generic_timeline()
    with pytest.raises(MseError) as missing:
        render(timeline, "bml", ExportOptions(face_library=tmp_path / "absent.xml"))
    assert missing.value.diagnostics[0].code == "E100"
    broken = tmp_path / "broken.xml"
    broken.write_text("<facelibrary>\n  <expression", encoding="utf-8")
    with pytest.raises(MseError) as malformed:
        render(timeline, "greta-bml", ExportOptions(face_library=broken))
    diagnostic = malformed.value.diagnostics[0]
    assert diagnostic.code == "E101" and diagnostic.span.line == 2


def test_unknown_format_is_a_diagnostic() -> None:
    with pytest.raises(MseError) as error:
        render(generic_timeline(), "pdf")
    assert error.value.diagnostics[0].code == "E130"
    assert "pdf" in error.value.diagnostics[0].message


def test_real_face_library_loads(greta_dir: Path) -> None:
    library = load_face_library(greta_dir / "facelibrary.xml")
    assert len(library.entries) > 100
    assert [u.number for u in library.entries[("gaze", "look_left")]] == [61]


def test_id_helpers() -> None:
    assert sanitize_id("a-b.c") == "a_b_c"
    assert sanitize_id("12") == "s_12"
    assert unique_ids(["a-b", "a_b", "a-b"]) == ["a_b", "a_b_2", "a_b_3"]
    assert [format_seconds(v) for v in (0.0, 1.5, 2.0, 0.1234, 1234567.5)] == [
        "0",
        "1.5",
        "2",
        "0.123",
        "1234567.5",
    ]


def test_empty_timeline_still_validates(bml_schema: etree.XMLSchema) -> None:
    for signals in ((), (TimelineSignal("x", "smell", "smell=roses", 0.0, 1.0),)):
        root = parse(render(Timeline("nothing", 2.0, signals), "bml"))
        assert bml_schema.validate(root), bml_schema.error_log
        assert root.find(f"{BML}wait") is not None


def test_greta_head_names_follow_greta_lexicon() -> None:
    root = parse(render(generic_timeline(), "greta-bml", ExportOptions(composition="replace")))
    assert root.get("composition") == "replace"
    head = root.find(f"{GRETA}head")
    assert head is not None and head.get("lexeme") == "Down"  # HeadGestures id, through greta.toml
    assert head.findtext(f"{GRETA}description/{GRETA}reference") == "Down"
