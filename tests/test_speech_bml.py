"""BML with speech sync: utterances as <speech> with word-boundary sync points; behaviours on a
boundary refer to it; Greta's and AsapRealizer's own parsers accept every generated dialogue
and resolve every reference to the time mse planned (bench/evaluation/speech_sync.py: 100 dialogues)."""

from __future__ import annotations

from pathlib import Path

import pytest
from lxml import etree

from mse.export import ExportOptions, render
from mse.export.speech_bml import SpokenWord, Utterance, speech_sync, tie_to_speech
from mse.export.xmltext import element
from mse.timeline import Timeline, TimelineSignal
from tests.realizer_harness import java_missing_reason
from tests.speech_sync_harness import generated_dialogues, verify, write_all

UTTERANCE = {
    "start": 0.4,
    "stop": 1.7,
    "text": "I can't believe it",
    "words": [["I", 0.4, 0.52], ["can't", 0.52, 0.8], ["believe", 0.8, 1.3], ["it", 1.5, 1.7]],
    "stress": ["believe"],
}


def _bml_schema(shared: Path) -> etree.XMLSchema:
    """The BML 1.0 XSD with ``part`` on ``<pose>``, which BML 1.0 requires and the XSD forbids
    (as tests/test_export_bml.py)."""
    tree = etree.parse(str(shared / "bml" / "bml-1.0.xsd"))
    xs = "{http://www.w3.org/2001/XMLSchema}"
    (pose_type,) = [t for t in tree.iter(f"{xs}complexType") if t.get("name") == "poseType"]
    etree.SubElement(pose_type, f"{xs}attribute", name="part", type="closedSetItem")
    return etree.XMLSchema(tree)


def dialogue() -> Timeline:
    signals = (
        TimelineSignal("nod", "head", "head=nod", 0.8, 1.3, episode=0),  # on "believe"
        TimelineSignal("frown", "face", "faceexp=frown", 0.1, 1.7, episode=0),  # ends with the last word
        TimelineSignal("gaze_away", "gaze", "gaze=look_down", 0.45, 1.0, episode=0),  # on no boundary
        TimelineSignal("speech1", "face", "faceexp=smile", 1.8, 2.0, episode=0),  # an id the speech must avoid
    )
    episodes = [
        {
            "index": 0,
            "emotion": "anger",
            "start": 0.0,
            "stop": 2.0,
            "announced": True,
            "interrupted": False,
            "intensity": 1.0,
        }
    ]
    return Timeline(
        "dialogue", 2.0, signals, solver="greedy", seed=1, extra={"episodes": episodes, "utterances": [UTTERANCE]}
    )


def test_sync_points_at_word_boundaries() -> None:
    words = tuple(SpokenWord(w[0], w[1], w[2]) for w in UTTERANCE["words"])  # type: ignore[index]
    sync = speech_sync([Utterance(0.4, 1.7, "I can't believe it", words)], taken=["speech1"])
    assert [(p.reference, p.time) for p in sync.points] == [
        ("speech1_:w1", 0.4),
        ("speech1_:w2", 0.52),
        ("speech1_:w3", 0.8),
        ("speech1_:e3", 1.3),
        ("speech1_:w4", 1.5),
        ("speech1_:e4", 1.7),
    ]
    assert sync.at(0.8004) is not None and sync.at(0.803) is None
    tied = tie_to_speech([element("head", {"id": "n", "start": "0.8", "end": "1.4"})], {"n": (0.8, 1.4)}, sync)
    assert tied.children[0].attributes == {"id": "n", "start": "speech1_:w3", "end": "1.4"}  # type: ignore[union-attr]


def test_bml_refers_to_words_and_validates(shared_dir: Path) -> None:
    text = render(dialogue(), "bml")
    root = etree.fromstring(text.encode())
    ns = "{http://www.bml-initiative.org/bml/bml-1.0}"
    speech = root.find(f"{ns}speech")
    assert speech is not None and speech.get("id") == "speech1_" and speech.get("start") == "0.4"
    assert "".join(speech.itertext()).strip() == "I can't believe it"
    head = root.find(f"{ns}head")
    face = next(f for f in root.findall(f"{ns}faceLexeme") if f.get("id") == "frown")
    gaze = root.find(f"{ns}gaze")
    assert (head.get("start"), head.get("end")) == ("speech1_:w3", "speech1_:e3")  # type: ignore[union-attr]
    assert (face.get("start"), face.get("end")) == ("0.1", "speech1_:e4")
    assert (gaze.get("start"), gaze.get("end")) == ("0.45", "1")  # type: ignore[union-attr]
    xsd = shared_dir / "bml" / "bml-1.0.xsd"
    if xsd.is_file():
        schema = etree.XMLSchema(etree.parse(str(xsd)))
        assert schema.validate(root), schema.error_log


def test_greta_speech_has_timed_marks_and_pitch_accents() -> None:
    root = etree.fromstring(render(dialogue(), "greta-bml").encode())
    ns = "{http://www.mindmakers.org/projects/BML}"
    speech = root.find(f"{ns}speech")
    assert speech is not None and (speech.get("start"), speech.get("end")) == ("0.4", "1.7")
    assert [(m.get("id"), m.get("time")) for m in speech.iter(f"{ns}tm")][:3] == [
        ("w1", "0.4"),
        ("w2", "0.52"),
        ("w3", "0.8"),
    ]
    (accent,) = speech.iter(f"{ns}pitchaccent")
    assert (accent.get("start"), accent.get("end")) == ("speech1_:w3", "speech1_:e3")


def test_a_timeline_without_speech_is_written_as_before() -> None:
    plain = Timeline("anger", 2.0, (TimelineSignal("nod", "head", "head=nod", 0.8, 1.3),), seed=1)
    assert "<speech" not in render(plain, "bml", ExportOptions()) and "<speech" not in render(plain, "greta-bml")


@pytest.mark.slow
def test_realizers_accept_generated_dialogues_and_resolve_every_reference(shared_dir: Path, tmp_path: Path) -> None:
    reason = java_missing_reason(shared_dir)
    if reason is not None:
        pytest.skip(reason)
    written = write_all(generated_dialogues(6, seed=1), tmp_path)
    schema = _bml_schema(shared_dir)
    for w in written:
        if w.profile == "generic":
            assert schema.validate(etree.parse(str(w.path))), (w.path.name, schema.error_log)
    verdict = verify(written, shared_dir, tmp_path)
    assert verdict.files == 24 and not verdict.rejected, verdict.rejected
    assert not verdict.problems, verdict.problems[:5]
    assert verdict.references > 50 and verdict.resolved == verdict.references


@pytest.mark.slow
def test_one_block_per_episode_for_a_live_realizer(shared_dir: Path, tmp_path: Path) -> None:
    """Per-episode blocks: unique ids bml_<dialogue>_<n>, times from the block's offset, speech in
    the block where it starts; both parsers accept them and time them as planned."""
    from mse.export.behaviours import plan_behaviours
    from mse.export.episode_bml import episode_blocks
    from tests.realizer_harness import greta_run_folder, run_asap, run_greta

    timeline = generated_dialogues(1, seed=5)[0]
    files: dict[str, list[tuple[Path, float]]] = {"bml": [], "greta-bml": []}
    ids = []
    for fmt in files:
        for block in episode_blocks(timeline, fmt):
            ids.append(block.id)
            path = tmp_path / fmt / f"{block.id}.xml"
            path.parent.mkdir(exist_ok=True)
            path.write_text(block.text, encoding="utf-8")
            files[fmt].append((path, block.offset))
    count = len(timeline.episodes)
    assert len(set(ids)) == count and ids[0].endswith("_1") and ids[count - 1].endswith(f"_{count}")
    assert sum(b.text.count("<speech ") for b in episode_blocks(timeline)) == len(timeline.utterances)
    reason = java_missing_reason(shared_dir)
    if reason is not None:
        pytest.skip(reason)
    asap = run_asap(shared_dir, [p for p, _ in files["bml"]])
    assert not [r.rejected for r in asap.values() if r.rejected]
    run_folder = greta_run_folder(shared_dir, shared_dir / "greta", tmp_path / "greta-run")
    greta = run_greta(shared_dir, run_folder, [p for p, _ in files["greta-bml"]])
    checked = 0
    for number, (path, offset) in enumerate(files["greta-bml"]):
        episode = [s for s in timeline.signals if s.episode == timeline.episodes[number]["index"]]
        planned = {b.id: (b.signal.start, b.signal.stop) for b in plan_behaviours(timeline.with_signals(episode))}
        for bid, (start, end) in greta[path].timed.items():
            if bid in planned:
                assert (start + offset, end + offset) == pytest.approx(planned[bid], abs=0.0015), (path.name, bid)
                checked += 1
    assert checked >= len(timeline.signals) - 3  # Greta leaves out a torso it lacks
