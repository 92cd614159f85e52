"""Dialogues (issue 28): scripts, the incremental session, episodes and their checks, `mse live`."""

from __future__ import annotations

import itertools
import json
import random
from dataclasses import replace
from pathlib import Path

import pytest

import mse
from mse.cli import main
from mse.diagnostics import MseError, Span
from mse.dialogue import EmotionEvent, SayEvent, Session, parse_event, plan_script, read_script
from mse.dialogue.check import check_dialogue
from mse.envelope import CUT_RELEASE, cut_envelope, envelope
from mse.ir.evaluate.episodes import CUT_RELEASE_TICKS
from mse.resources import bundled_names
from mse.timeline import Timeline, concatenate

SCRIPT = [
    {"t": 0.0, "emotion": "anger", "intensity": 0.8, "until": 3.7},
    {"t": 0.4, "say": "I can't believe you did that", "words": [["I", 0.4, 0.52], ["can't", 0.52, 0.8],
                                                                ["believe", 0.8, 1.2]], "stress": ["believe"]},
    {"t": 3.7, "emotion": "relief"},
    {"t": 4.0, "say": "Oh well, fine."},
    {"t": 8.7, "end": True},
]


def write_script(folder: Path, events: list[dict[str, object]] | list[str], name: str = "talk.jsonl") -> Path:
    path = folder / name
    lines = [e if isinstance(e, str) else json.dumps(e) for e in events]
    path.write_text("".join(line + "\n" for line in lines), encoding="utf-8")
    return path


def random_script(rng: random.Random, pool: list[str], seconds: float) -> list[dict[str, object]]:
    events: list[dict[str, object]] = []
    t = 0.0
    while t < seconds - 2:
        nxt = round(min(seconds, t + rng.uniform(2, 20)), 3)
        event: dict[str, object] = {"t": round(t, 3), "emotion": rng.choice(pool),
                                    "intensity": round(rng.uniform(0.2, 1), 2)}
        kind = rng.random()
        if kind < 0.5:
            event["until"] = nxt
        elif kind < 0.7:
            event["until"] = round(nxt + rng.uniform(0.5, 4), 3)
        events.append(event)
        t = nxt
    events.append({"t": seconds, "end": True})
    return events


# -- the script format ----------------------------------------------------------------------------
def test_script_reads_every_kind_of_event(tmp_path: Path) -> None:
    events = read_script(write_script(tmp_path, SCRIPT))
    assert [type(e).__name__ for e in events] == ["EmotionEvent", "SayEvent", "EmotionEvent", "SayEvent", "EndEvent"]
    said = events[1]
    assert isinstance(said, SayEvent) and [w.text for w in said.stressed_words()] == ["believe"]
    estimated = events[3]
    assert isinstance(estimated, SayEvent) and estimated.words[0].start == 4.0
    assert [w.text for w in estimated.words] == ["Oh", "well,", "fine."]  # 14 characters a second
    assert estimated.stop == pytest.approx(4.0 + 15 / 14, abs=0.002)


@pytest.mark.parametrize(
    ("line", "expected"),
    [
        ('{"t": 0, "emotion": "anger"', "invalid JSON"),
        ('{"t": 0, "emotion": "angr"}', "did you mean 'anger'?"),
        ('{"t": 0, "emotion": "anger", "intesity": 1}', "did you mean 'intensity'?"),
        ('{"t": 0, "emotoin": "anger"}', "did you mean 'emotion'?"),
        ('{"t": 0, "emotion": "anger", "intensity": 2}', "'intensity' must be a number in [0, 1]"),
        ('{"t": 1, "emotion": "anger", "until": 0.5}', "'until' 0.5 s must be after"),
        ('{"t": 0, "say": "a b", "words": [["a", -1, 0.2]]}', "outside"),
        ('{"t": 1, "say": "a b", "words": [["a", 0.5, 0.9]]}', "before its utterance"),
        ('{"t": 1, "say": "a b", "words": [["a", 1, 1.5], ["b", 1.2, 1.6]]}', "do not overlap"),
        ('{"t": 1, "say": "a b", "stress": ["c"]}', "stressed word 'c' is not among"),
        ('[1, 2]', "an event must be a JSON object"),
    ],
)
def test_a_bad_line_gets_file_line_and_a_clear_message(tmp_path: Path, line: str, expected: str) -> None:
    path = write_script(tmp_path, ['{"t": 0, "emotion": "relief"}', line] if '"t": 0,' not in line else [line])
    with pytest.raises(MseError) as caught:
        read_script(path)
    rendered = str(caught.value)
    assert expected in rendered
    line_number = 2 if '"t": 0,' not in line else 1
    assert f"{path}:{line_number}:" in rendered


@pytest.mark.parametrize(
    ("events", "expected"),
    [
        ([{"t": 2, "emotion": "anger"}, {"t": 1, "emotion": "relief"}], "out of order"),
        ([{"t": 0, "emotion": "anger"}, {"t": 1, "say": "one two three four five six"},
          {"t": 1.5, "say": "again"}], "overlaps the previous one"),
        ([{"t": 0, "say": "hello"}, {"t": 1, "emotion": "anger"}], "first event must be an emotion"),
        ([{"t": 0, "emotion": "anger"}, {"t": 2, "end": True}, {"t": 3, "emotion": "relief"}],
         "after the dialogue's end"),
        ([{"t": 0, "emotion": "anger"}, {"t": 1, "say": "one two three four five six"}, {"t": 1.5, "end": True}],
         "after the dialogue's end"),
    ],
)
def test_sequence_errors_write_nothing(tmp_path: Path, events: list[dict[str, object]], expected: str,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    path = write_script(tmp_path, events)
    out = tmp_path / "out.json"
    assert main(["live", str(path), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert expected in err and "E217" in err and f"{path}:" in err
    assert not out.exists() and not list(tmp_path.glob(".*tmp*"))


def test_schema_ships_and_matches_the_reader() -> None:
    import importlib.resources

    schema = json.loads((importlib.resources.files("mse.dialogue") / "script.schema.json").read_text())
    kinds = {branch["title"]: set(branch["properties"]) for branch in schema["oneOf"]}
    from mse.dialogue.script import EMOTION_KEYS, END_KEYS, SAY_KEYS

    assert kinds == {"emotion": set(EMOTION_KEYS), "say": set(SAY_KEYS), "end": set(END_KEYS)}


def test_a_set_file_next_to_the_script(tmp_path: Path) -> None:
    (tmp_path / "mine.xml").write_text((Path(mse.__file__).parent.parent / "behaviour_sets" / "relief.xml")
                                       .read_text(encoding="utf-8").replace('name="relief"', 'name="mine"'))
    event = parse_event({"t": 0, "emotion": "mine.xml"}, Span(str(tmp_path / "talk.jsonl"), 1, 1))
    assert isinstance(event, EmotionEvent)
    timeline = plan_script([event, parse_event({"t": 5, "end": True}, Span("x", 2, 1))], seed=1, base=tmp_path)
    assert timeline.episodes[0]["source"]["path"].endswith("mine.xml")
    assert check_dialogue(timeline) == []


# -- episodes -------------------------------------------------------------------------------------
def test_announced_episodes_are_expressions_of_exactly_their_length(tmp_path: Path) -> None:
    timeline = plan_script(read_script(write_script(tmp_path, SCRIPT)), seed=3)
    first, second = timeline.episodes
    assert (first["start"], first["stop"], first["announced"], first["interrupted"]) == (0.0, 3.7, True, False)
    assert (second["start"], second["stop"], second["announced"], second["interrupted"]) == (3.7, 8.7, False, True)
    anger = [s for s in timeline.signals if s.episode == 0]
    assert anger and all(s.start >= 0 and s.stop <= 3.7 and not s.cut for s in anger)
    model = mse.load("anger")
    alone = Timeline("anger", 3.7, tuple(replace(s, start=s.start, stop=s.stop) for s in anger))
    assert mse.check(model, alone) == []
    assert check_dialogue(timeline) == []
    assert timeline.utterances[0]["stress"] == ["believe"] and timeline.utterances[0]["stop"] == 1.2


@pytest.mark.slow
def test_every_set_in_random_dialogues_is_consistent_episode_by_episode() -> None:
    rng = random.Random(5)
    pool = bundled_names()
    for number in range(6):
        events = random_script(rng, pool, 120.0)
        timeline = plan_script([parse_event(e, Span("<t>", n + 1, 1)) for n, e in enumerate(events)], seed=number)
        assert check_dialogue(timeline) == [], number
        assert timeline.duration == 120.0
        episodes = timeline.episodes
        assert episodes[0]["start"] == 0 and episodes[-1]["stop"] == 120.0
        assert all(a["stop"] == b["start"] for a, b in itertools.pairwise(episodes))
        for signal in timeline.signals:
            assert signal.envelope is not None
            shape = signal.envelope
            assert shape.attack + shape.sustain + shape.release == pytest.approx(signal.stop - signal.start, abs=0.004)


def test_an_interruption_cuts_open_occurrences_and_drops_later_ones(tmp_path: Path) -> None:
    session = Session(seed=2)
    planned = session.emotion(0.0, "embarrassment")  # unannounced: a horizon of 10 s
    cut_at = next(s for s in planned if s.stop - s.start > 1).start + 0.5
    session.emotion(round(cut_at, 3), "relief", until=round(cut_at + 5, 3))
    session.end(round(cut_at + 5, 3))
    timeline = session.timeline()
    first = timeline.episodes[0]
    assert first["interrupted"] and first["plan_stop"] == 10.0 and first["stop"] == round(cut_at, 3)
    cut = [s for s in timeline.signals if s.episode == 0 and s.cut]
    assert cut and all(s.start < first["stop"] < s.planned_stop for s in cut)
    assert all(first["stop"] <= s.stop <= min(s.planned_stop, first["stop"] + CUT_RELEASE) for s in cut)
    dropped = first.get("dropped", [])
    assert all(d["start"] >= first["stop"] for d in dropped)
    assert check_dialogue(timeline) == []
    # the plan, restored, is a consistent expression of the horizon
    whole = [replace(s, stop=s.planned_stop or s.stop) for s in timeline.signals if s.episode == 0]
    restored = [*whole, *(mse.TimelineSignal(d["id"], "", "", d["start"], d["stop"]) for d in dropped)]
    assert mse.check(mse.load("embarrassment"), Timeline("embarrassment", 10.0, tuple(restored))) == []


@pytest.mark.slow
def test_an_event_changes_nothing_before_its_time() -> None:
    rng = random.Random(11)
    events = random_script(rng, bundled_names(), 90.0)[:-1]
    for cut in range(1, len(events)):
        longer, shorter = Session(seed=4), Session(seed=4)
        for event in events[:cut + 1]:
            longer.feed(parse_event(event, Span("<t>")))
        for event in events[:cut]:
            shorter.feed(parse_event(event, Span("<t>")))
        t = float(events[cut]["t"])  # type: ignore[arg-type]
        before = {(s.id, s.start) : s for s in shorter.timeline().signals if s.start < t}
        after = {(s.id, s.start): s for s in longer.timeline().signals if s.start < t}
        assert before.keys() == after.keys()
        for key, signal in before.items():
            changed = after[key]
            assert min(signal.stop, t) == min(changed.stop, t)  # what was shown before t stays


def test_check_names_the_episode_and_the_constraint(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    timeline = plan_script(read_script(write_script(tmp_path, SCRIPT)), seed=3)
    broken = [s for s in timeline.signals if s.episode == 0]
    bad = timeline.with_signals([s for s in timeline.signals if s not in broken[:1]] +
                                [replace(broken[0], start=3.6, stop=3.69)])
    (tmp_path / "bad.json").write_text(bad.dumps())
    assert main(["check", str(tmp_path / "bad.json")]) == 1
    out = capsys.readouterr().out
    assert "[episode 0 (anger)]" in out and "anger.xml:" in out
    (tmp_path / "good.json").write_text(timeline.dumps())
    assert main(["check", str(tmp_path / "good.json")]) == 0
    assert "(2 of 2 episodes)" in capsys.readouterr().out
    assert main(["check", "anger", str(tmp_path / "good.json")]) == 1
    assert "check it alone" in capsys.readouterr().err
    plain = tmp_path / "plain.json"
    plain.write_text(mse.sample(mse.load("anger"), 5.0, seed=1).dumps())  # type: ignore[union-attr]
    assert main(["check", str(plain)]) == 1
    assert "has no episodes" in capsys.readouterr().err


def test_a_gap_between_episodes_is_a_violation(tmp_path: Path) -> None:
    timeline = plan_script(read_script(write_script(tmp_path, SCRIPT)), seed=3)
    episodes = timeline.episodes
    episodes[1] = {**episodes[1], "start": 3.9}
    gap = replace(timeline, extra={**timeline.extra, "episodes": episodes})
    assert any("gap between episodes" in v.violation.message for v in check_dialogue(gap))


def test_shift_and_concatenation_keep_episodes_checkable() -> None:
    model = mse.load("relief")
    a = mse.sample(model, 4.0, seed=1)
    b = mse.sample(mse.load("anger"), 6.0, seed=2)
    assert isinstance(a, Timeline) and isinstance(b, Timeline)
    joined = concatenate([a, b, a])
    assert joined.duration == 14.0
    assert [e["emotion"] for e in joined.episodes] == ["relief", "anger", "relief"]
    assert [(e["start"], e["stop"]) for e in joined.episodes] == [(0.0, 4.0), (4.0, 10.0), (10.0, 14.0)]
    assert check_dialogue(joined) == []
    shifted = a.shift(2.5)
    assert shifted.duration == 6.5 and all(s.start >= 2.5 for s in shifted.signals)
    assert check_dialogue(shifted.then(b)) != []  # 0-2.5 s belongs to no episode: a gap


SMILING = """<expression name="{name}"><signals>
  <signal id="{name}_smile" modality="face" lexeme="faceexp=smile" min_duration="3" max_duration="6"
          probability_start="1" probability_end="1"/>
  <signal id="{name}_nod" modality="head" lexeme="head={name}" min_duration="1" max_duration="2"/>
</signals><constraints><constraint id="smiles">exists({name}_smile)</constraint></constraints></expression>"""


def test_a_shared_lexeme_carries_over(tmp_path: Path) -> None:
    for name in ("happy", "proud"):
        (tmp_path / f"{name}.xml").write_text(SMILING.format(name=name))
    found = 0
    for seed in range(40):
        session = Session(seed=seed, base=tmp_path)
        session.emotion(0.0, "happy.xml")  # not announced: the change at 2.5 s interrupts it
        session.emotion(2.5, "proud.xml", until=8.0)
        session.end(8.0)
        timeline = session.timeline()
        for signal in timeline.signals:
            if signal.carry:
                found += 1
                before = [s for s in timeline.signals if s.episode == 0 and s.lexeme == signal.lexeme
                          and s.stop == max(signal.start, 2.5)]
                assert before and before[0].envelope is not None and before[0].envelope.release == 0
                assert signal.envelope is not None and signal.envelope.attack == 0
        assert check_dialogue(timeline) == []
    assert found > 0


# -- intensity and envelope ------------------------------------------------------------------------
def test_envelope_is_one_definition() -> None:
    shape = envelope("head", 1.0, 3.0, 0.5)
    assert (shape.intensity, shape.attack, shape.release) == (0.5, 0.35, 0.35)
    stop, cut = cut_envelope("face", 0.0, 5.0, 2.0, 0.7)
    assert stop == 2.0 + CUT_RELEASE and cut.release == pytest.approx(CUT_RELEASE) and cut.attack == 0.3
    assert round(CUT_RELEASE * 1000) == CUT_RELEASE_TICKS


def test_intensity_is_the_events_times_the_signals(tmp_path: Path) -> None:
    text = (Path(mse.__file__).parent.parent / "behaviour_sets" / "relief.xml").read_text(encoding="utf-8")
    soft = text.replace('<signal id="', '<signal intensity="0.5" id="', 1)
    (tmp_path / "soft.xml").write_text(soft)
    model = mse.load(tmp_path / "soft.xml")
    halved = model.signals[0].id
    assert model.signals[0].intensity == 0.5 and model.signals[1].intensity == 1.0
    from mse.ir.canonical import model_from_json, model_to_json
    from mse.ir.decode import model_from_trusted_json

    assert model_from_json(model_to_json(model)).signals[0].intensity == 0.5
    assert model_from_trusted_json(model_to_json(model)).signals[0].intensity == 0.5
    for seed in range(20):
        timeline = plan_script([parse_event({"t": 0, "emotion": "soft.xml", "intensity": 0.8},
                                            Span(str(tmp_path / "s.jsonl"), 1, 1)),
                                parse_event({"t": 10, "end": True}, Span("x", 2, 1))], seed=seed, base=tmp_path)
        for signal in timeline.signals:
            assert signal.envelope is not None
            assert signal.envelope.intensity == pytest.approx(0.4 if signal.id == halved else 0.8)
    bad = text.replace('<signal id="', '<signal intensity="1.5" id="', 1)
    (tmp_path / "bad.xml").write_text(bad)
    with pytest.raises(MseError, match=r"E204 intensity=1\.5 must be in"):
        mse.load(tmp_path / "bad.xml")


def test_face_and_bml_read_the_intensity(tmp_path: Path) -> None:
    from mse.export import ExportOptions, render
    from mse.export.face.page import face_track

    timeline = plan_script(read_script(write_script(tmp_path, SCRIPT)), seed=3)
    bml = render(timeline, "bml")
    assert 'amount="0.8"' in bml  # anger at 0.8
    track = face_track(timeline, ExportOptions())
    keys = {k.signal: k for k in track.keys}
    plain = face_track(Timeline("x", 8.7, tuple(replace(s, envelope=None) for s in timeline.signals)),
                       ExportOptions())
    for key in plain.keys:
        if key.signal in keys and timeline.signals[0].episode == 0 and key.targets:
            mine = dict(keys[key.signal].targets)
            if next(s for s in timeline.signals if s.id == key.signal).episode == 0:
                assert all(mine[c] == pytest.approx(v * 0.8, abs=1e-3) for c, v in key.targets)


# -- CLI ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("fmt", ["json", "table", "bml", "greta-bml", "svg", "html", "eaf"])
def test_live_writes_every_format(tmp_path: Path, fmt: str) -> None:
    path = write_script(tmp_path, SCRIPT)
    out = tmp_path / f"out.{fmt}"
    assert main(["live", str(path), "--seed", "3", "--format", fmt, "-o", str(out)]) == 0
    assert out.stat().st_size > 0


def test_live_json_is_the_session_timeline(tmp_path: Path) -> None:
    path = write_script(tmp_path, SCRIPT)
    out = tmp_path / "dialogue.json"
    assert main(["live", str(path), "--seed", "3", "-o", str(out)]) == 0
    assert json.loads(out.read_text()) == plan_script(read_script(path), seed=3).to_json()
    assert Timeline.from_json(json.loads(out.read_text())).to_json() == json.loads(out.read_text())


def test_bml_block_ids_and_composition(tmp_path: Path) -> None:
    path = write_script(tmp_path, SCRIPT)
    ids = set()
    for seed in (1, 2):
        out = tmp_path / f"d{seed}.bml"
        assert main(["live", str(path), "--seed", str(seed), "-o", str(out), "--composition", "append"]) == 0
        text = out.read_text()
        assert 'composition="APPEND"' in text
        ids.add(text.split(' id="', 1)[1].split('"', 1)[0])
    assert len(ids) == 2
    out = tmp_path / "r.bml"
    assert main(["sample", "relief", "--seed", "1", "--format", "bml", "-o", str(out), "--bml-id", "turn7",
                 "--composition", "REPLACE"]) == 0
    text = out.read_text()
    assert 'id="turn7"' in text and 'composition="REPLACE"' in text


def test_a_cut_that_is_not_the_plan_cut_is_reported() -> None:
    for seed in range(30):
        session = Session(seed=seed)
        planned = session.emotion(0.0, "embarrassment")
        open_at = [s for s in planned if s.stop - s.start > 1.0]
        if not open_at:
            continue
        t = round(open_at[0].start + 0.5, 3)
        session.emotion(t, "relief", until=round(t + 4, 3))
        session.end(round(t + 4, 3))
        timeline = session.timeline()
        cut = next(s for s in timeline.signals if s.cut)
        late = timeline.with_signals([replace(s, stop=round(t + 0.5, 3)) if s is cut else s
                                      for s in timeline.signals])
        assert any("releases within" in v.violation.message for v in check_dialogue(late))
        uncut = timeline.with_signals([replace(s, planned_stop=None) if s is cut else s for s in timeline.signals])
        assert any(v.episode == 0 for v in check_dialogue(uncut))
        return
    pytest.fail("no seed gave an occurrence open at the change")


def test_live_reads_standard_input(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    import io
    import sys

    text = "".join(json.dumps(e) + "\n" for e in SCRIPT)
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(text.encode())))
    assert main(["live", "-", "--seed", "3"]) == 0
    assert json.loads(capsys.readouterr().out)["episodes"][1]["emotion"] == "relief"
