"""Speech anchors (docs/semantics.md, "Speech anchors"): the syntax, the IR and its JSON, the
resolution into constants, lint's note, both solvers on resolved models (each output re-checked
by the evaluator and by a check written here from the docs), and the CLI."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from html import escape
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mse.api import loads
from mse.diagnostics import MseError
from mse.ir import model as ir
from mse.ir.anchors import (
    Speech,
    Word,
    episode_speech,
    resolve_anchors,
    utterance_from_json,
    without_anchored,
)
from mse.ir.canonical import model_from_json, model_to_json
from mse.ir.decode import decode_expr
from mse.ir.evaluate import check_schedule
from mse.ir.lint import lint_model
from mse.ir.printer import expr_text
from mse.ir.schedule import Occurrence, Schedule, to_ticks
from mse.sampling import iter_timelines, sample

FIXTURES = Path(__file__).resolve().parent / "fixtures" / "speech"
REPO = Path(__file__).resolve().parent.parent

SET = """<?xml version="1.0"?>
<expression name="talk">
  <signals>
    <signal id="nod" modality="head" lexeme="head=nod" min_duration="0.3" max_duration="0.8"
            probability_start="0.5" probability_end="0.5"/>
    <signal id="gaze_away" modality="gaze" lexeme="gaze=away" min_duration="0.4" max_duration="2"
            probability_start="0.5" probability_end="0.5"/>
    <signal id="smile" modality="face" lexeme="faceexp=smile" min_duration="1" max_duration="3"
            probability_start="0.5" probability_end="0.5"/>
  </signals>
  <constraints>
    <constraint id="nod_on_stress">equal(start(nod), stressed, 0.2)</constraint>
    <constraint id="away_at_turn">equal(start(gaze_away), speech.start, 0.3)</constraint>
    <constraint id="back_before_end">stop(gaze_away) &lt;= speech.stop - 0.2</constraint>
    <constraint id="smile_after">start(smile) &gt;= stressed.stop</constraint>
  </constraints>
</expression>
"""


def _model(constraints: str = "", signals: str = "") -> ir.Model:
    if not constraints:
        return loads(SET, path="talk.xml")
    signals = signals or '<signal id="nod" modality="head" min_duration="0.3" max_duration="0.8"/>'
    return loads(
        f'<expression name="t"><signals>{signals}</signals><constraints>{constraints}</constraints></expression>',
        path="t.xml",
    )


# -- syntax and IR ------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("written", "anchor", "offset", "printed"),
    [
        ("start(nod) >= speech.start - 0.5", "start", -500, "start(nod) >= speech.start - 0.5"),
        ("stop(nod) < speech.stop", "stop", 0, "stop(nod) < speech.stop"),
        ("equal(start(nod), stressed, 0.2)", "stressed_start", 0, "equal(start(nod), stressed, 0.2)"),
        ("start(nod) > stressed.start + 0.1", "stressed_start", 100, "start(nod) > stressed + 0.1"),
        ("stressed.stop + 1 <= stop(nod)", "stressed_stop", 1000, "stressed.stop + 1 <= stop(nod)"),
    ],
)
def test_each_spelling_parses_prints_and_round_trips(written: str, anchor: str, offset: int, printed: str) -> None:
    model = _model(f"<constraint>{escape(written)}</constraint>")
    atom = model.constraints[0].expr
    assert isinstance(atom, ir.Compare)
    term = atom.left if isinstance(atom.left, ir.SpeechTime) else atom.right
    assert term == ir.SpeechTime(anchor, offset)  # type: ignore[arg-type]
    assert term.span.line == 1 and term.span.col > 0
    assert expr_text(atom) == printed
    assert _model(f"<constraint>{escape(printed)}</constraint>").constraints[0].expr == atom
    as_json = model_to_json(model)
    assert model_from_json(json.loads(json.dumps(as_json))).constraints[0].expr == atom
    assert decode_expr(as_json["constraints"][0]["expr"], atom.span) == atom


def test_anchor_words_stay_signal_names_where_a_signal_is_expected() -> None:
    signals = ('<signal id="stressed" modality="head" min_duration="0.3"/>'
               '<signal id="stressedness" modality="face" min_duration="0.3"/>')
    model = _model("<constraint>start(stressed) &lt; start(stressedness)</constraint>", signals)
    assert model.constraints[0].expr == ir.Compare(
        "<", ir.SignalTime("stressed", "start"), ir.SignalTime("stressedness", "start")
    )


def test_a_misspelt_anchor_is_a_located_syntax_error() -> None:
    with pytest.raises(MseError) as caught:
        _model("<constraint>start(nod) &gt; stresed</constraint>")
    diagnostic = caught.value.diagnostics[0]
    assert diagnostic.code == "E110" and "stressed" in diagnostic.message


# -- resolution -----------------------------------------------------------------------------------------
SPEECH = utterance_from_json(
    {"start": 0.4, "stop": 2.2, "stress": ["believe", "that"],
     "words": [["I", 0.4, 0.52], ["can't", 0.52, 0.8], ["believe", 0.8, 1.25], ["that", 1.62, 2.2]]},
    ir.NO_SPAN,
)


def test_resolve_rewrites_speech_into_constants_and_stress_into_or() -> None:
    resolved = resolve_anchors(_model(), SPEECH)
    by_id = {c.id: c.expr for c in resolved.constraints}
    assert by_id["nod_on_stress"] == ir.Or((
        ir.Compare("=", ir.SignalTime("nod", "start"), ir.Constant(800), 200),
        ir.Compare("=", ir.SignalTime("nod", "start"), ir.Constant(1620), 200),
    ))
    assert by_id["away_at_turn"] == ir.Compare("=", ir.SignalTime("gaze_away", "start"), ir.Constant(400), 300)
    assert by_id["back_before_end"] == ir.Compare("<=", ir.SignalTime("gaze_away", "stop"), ir.Constant(2000))
    assert by_id["smile_after"] == ir.Or((
        ir.Compare(">=", ir.SignalTime("smile", "start"), ir.Constant(1250)),
        ir.Compare(">=", ir.SignalTime("smile", "start"), ir.Constant(2200)),
    ))
    # the constraint keeps its text and position for violation messages
    assert resolved.constraints[0].text == "equal(start(nod), stressed, 0.2)"
    assert resolved.constraints[0].span.line > 0


def test_a_model_without_anchors_is_returned_as_it_is() -> None:
    model = _model("<constraint>start(nod) &gt; 1</constraint>")
    assert resolve_anchors(model, None) is model
    assert resolve_anchors(model, SPEECH) is model


def test_anchors_without_speech_are_a_located_error() -> None:
    with pytest.raises(MseError) as caught:
        resolve_anchors(_model(), None)
    diagnostics = caught.value.diagnostics
    assert [d.code for d in diagnostics] == ["E219"] * 4
    assert all(d.span.path == "talk.xml" and d.span.line > 0 for d in diagnostics)
    # a solver handed an unresolved model says the same, never a traceback
    with pytest.raises(MseError) as solved:
        sample(_model(), 4, seed=1, solver="cpsat")
    assert solved.value.diagnostics[0].code == "E219"


def test_no_stressed_word_makes_the_comparison_false_when_its_signals_occur() -> None:
    plain = Speech(0.4, 2.2, (Word("hello", 0.4, 1.0),))
    resolved = resolve_anchors(_model("<constraint>equal(start(nod), stressed, 0.2)</constraint>"), plain)
    with_nod = Schedule.of(4000, [Occurrence(1000, 1500, "nod")])
    assert [v.constraint for v in check_schedule(resolved, with_nod)] == ["c1"]
    assert check_schedule(resolved, Schedule.of(4000, [])) == []  # not instantiated, as before


def test_several_utterances_join() -> None:
    first = Speech(0.5, 1.0, (Word("yes", 0.5, 1.0, stressed=True),))
    second = Speech(2.0, 3.0, (Word("no", 2.0, 2.4), Word("way", 2.4, 3.0, stressed=True)))
    joined = Speech.join([second, first])
    assert (joined.start, joined.stop) == (0.5, 3.0)
    assert [w.text for w in joined.stressed] == ["yes", "way"]


@pytest.mark.parametrize(
    ("obj", "message"),
    [
        ([1, 2], "JSON object"),
        ({"start": 1, "stop": 0.5}, "before 'start'"),
        ({"start": 1, "stop": 2, "words": [["a", 0.5, 1.2]]}, "outside the utterance"),
        ({"start": 0, "stop": 2, "words": [["a", 0.5, 1.2], ["b", 1.0, 1.5]]}, "do not overlap"),
        ({"start": 0, "stop": 2, "words": [["a", 0.5, 1.2]], "stress": ["b"]}, "not among"),
        ({"start": 0, "stop": 2, "words": [["a", 0.5]]}, "[word, start, stop]"),
        ({"start": "0"}, "number of seconds"),
        ({"start": 0, "strss": []}, "did you mean 'stress'"),
    ],
)
def test_malformed_speech_is_refused_clearly(obj: object, message: str) -> None:
    with pytest.raises(MseError) as caught:
        utterance_from_json(obj, ir.NO_SPAN)
    assert caught.value.diagnostics[0].code == "E220"
    assert message in caught.value.diagnostics[0].message


def test_lint_notes_each_anchored_constraint_and_deep_lint_leaves_them_out() -> None:
    model = _model()
    notes = [d for d in lint_model(model) if d.code == "N313"]
    assert len(notes) == 4 and all(d.span.line > 0 for d in notes)
    assert without_anchored(model).constraints == ()


# -- both solvers on resolved models ------------------------------------------------------------------------
@st.composite
def speeches(draw: st.DrawFn) -> Speech:
    at = draw(st.integers(0, 2000))
    start = at
    words = []
    for index in range(draw(st.integers(1, 6))):
        at += draw(st.integers(0, 200))
        length = draw(st.integers(80, 500))
        words.append(Word(f"w{index}", at / 1000, (at + length) / 1000, draw(st.booleans())))
        at += length
    return Speech(start / 1000, at / 1000, tuple(words))


def _independent_violations(speech: Speech, signals: dict[str, list[tuple[int, int]]]) -> list[str]:
    """The fixture's four constraints, straight from docs/semantics.md (integer ms)."""
    stressed = [(to_ticks(w.start), to_ticks(w.stop)) for w in speech.words if w.stressed]
    found = []
    nods = signals.get("nod", [])
    if nods and not any(all(abs(start - word[0]) <= 200 for start, _ in nods) for word in stressed):
        found.append("nod_on_stress")
    for start, stop in signals.get("gaze_away", []):
        if abs(start - to_ticks(speech.start)) > 300:
            found.append("away_at_turn")
        if stop > to_ticks(speech.stop) - 200:
            found.append("back_before_end")
    smiles = signals.get("smile", [])
    if smiles and not any(all(start >= word[1] for start, _ in smiles) for word in stressed):
        found.append("smile_after")
    return found


def _occurrences(timeline: object) -> dict[str, list[tuple[int, int]]]:
    grouped: dict[str, list[tuple[int, int]]] = {}
    for signal in timeline.signals:  # type: ignore[attr-defined]
        grouped.setdefault(signal.id, []).append((to_ticks(signal.start), to_ticks(signal.stop)))
    return grouped


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(speech=speeches(), seed=st.integers(0, 2**31 - 1))
def test_greedy_on_resolved_models_keeps_every_anchor(speech: Speech, seed: int) -> None:
    resolved = resolve_anchors(_model(), speech)
    for timeline in iter_timelines(resolved, 5.0, seed=seed, count=3):
        assert check_schedule(resolved, timeline.to_schedule()) == []
        assert _independent_violations(speech, _occurrences(timeline)) == []


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(speech=speeches(), seed=st.integers(0, 2**31 - 1))
def test_cpsat_on_resolved_models_keeps_every_anchor(speech: Speech, seed: int) -> None:
    resolved = resolve_anchors(_model(), speech)
    timeline = sample(resolved, 5.0, seed=seed, solver="cpsat")
    assert not isinstance(timeline, list)
    assert check_schedule(resolved, timeline.to_schedule()) == []
    assert _independent_violations(speech, _occurrences(timeline)) == []


def test_the_independent_check_agrees_with_the_evaluator_on_placed_signals() -> None:
    """The independent check is not vacuous: timelines that break each constraint."""
    resolved = resolve_anchors(_model(), SPEECH)
    cases = {
        "nod_on_stress": [Occurrence(1100, 1500, "nod")],
        "away_at_turn": [Occurrence(900, 1500, "gaze_away")],
        "back_before_end": [Occurrence(400, 2100, "gaze_away")],
        "smile_after": [Occurrence(1000, 2500, "smile")],
    }
    for constraint, occurrences in cases.items():
        schedule = Schedule.of(5000, occurrences)
        grouped = {o.signal: [(o.start, o.stop)] for o in occurrences}
        assert [v.constraint for v in check_schedule(resolved, schedule)] == [constraint]
        assert _independent_violations(SPEECH, grouped) == [constraint]


# -- command line -------------------------------------------------------------------------------------------
def _mse(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "mse", *args], capture_output=True, text=True, input=stdin, cwd=REPO, timeout=120,
        check=False,
    )


@pytest.mark.slow
@pytest.mark.parametrize("solver", ["greedy", "cpsat"])
def test_cli_sample_with_speech_then_check(solver: str, tmp_path: Path) -> None:
    talking, speech = FIXTURES / "talking.xml", FIXTURES / "utterance.json"
    out = tmp_path / "t.json"
    done = _mse("sample", str(talking), "--speech", str(speech), "-d", "4", "--seed", "7", "--solver", solver,
                "-o", str(out))
    assert done.returncode == 0, done.stderr
    checked = _mse("check", str(talking), str(out), "--speech", str(speech))
    assert checked.returncode == 0, checked.stdout + checked.stderr
    # the same speech as the timeline's own utterances (the dialogue format)
    timeline = json.loads(out.read_text())
    timeline["utterances"] = [{**json.loads(speech.read_text()), "text": "I can't believe you did that", "index": 0}]
    with_utterances = tmp_path / "u.json"
    with_utterances.write_text(json.dumps(timeline))
    assert _mse("check", str(talking), str(with_utterances)).returncode == 0


@pytest.mark.slow
def test_cli_anchors_without_speech_and_bad_speech(tmp_path: Path) -> None:
    talking = str(FIXTURES / "talking.xml")
    missing = _mse("sample", talking, "-d", "4")
    assert missing.returncode == 1 and "E219" in missing.stderr and "talking.xml:11:" in missing.stderr
    assert missing.stdout == ""
    bad = tmp_path / "bad.json"
    bad.write_text('{"start": 0.4,\n "words": [["I", 0.4]]}')
    refused = _mse("sample", talking, "-d", "4", "--speech", str(bad))
    assert refused.returncode == 1 and f"{bad}: E220" in refused.stderr and "Traceback" not in refused.stderr
    bad.write_text('{"start": 0.4,\n "words": [')
    broken = _mse("check", talking, str(bad), "--speech", str(bad))
    assert broken.returncode == 1 and "E2" in broken.stderr and "Traceback" not in broken.stderr


def test_samples_place_every_anchored_signal() -> None:
    """The property tests above are not vacuous: both solvers place each anchored signal."""
    resolved = resolve_anchors(_model(), SPEECH)
    for solver in ("greedy", "cpsat"):
        placed: set[str] = set()
        for timeline in iter_timelines(resolved, 5.0, seed=1, count=60, solver=solver):
            placed.update(_occurrences(timeline))
        assert placed == {"nod", "gaze_away", "smile"}, solver


def test_episode_speech_is_the_overlapping_utterances_in_the_episode_time() -> None:
    first = Speech(1.0, 2.0, (Word("yes", 1.0, 2.0, stressed=True),))
    second = Speech(4.5, 6.0, (Word("no", 4.5, 5.2), Word("way", 5.2, 6.0, stressed=True)))
    episode = episode_speech([first, second], 4.0, 8.0)
    assert episode == Speech(0.5, 2.0, (Word("no", 0.5, 1.2), Word("way", 1.2, 2.0, stressed=True)))
    assert episode_speech([first, second], 2.0, 4.5) is None  # touching is not overlapping
    spanning = episode_speech([first, second], 1.5, None)
    assert spanning is not None and spanning.start == -0.5 and [w.text for w in spanning.stressed] == ["yes", "way"]


def test_a_dialogue_checks_each_episode_against_the_speech_overlapping_it() -> None:
    """Episodes resolve their anchors with episode_speech: the utterances that overlap them, in
    the episode's own time; a timeline's utterances follow it through shift and then."""
    from mse.api import load
    from mse.dialogue.check import check_dialogue

    talking = load(FIXTURES / "talking.xml")
    raw = json.loads((FIXTURES / "utterance.json").read_text())
    resolved = resolve_anchors(talking, utterance_from_json(raw, ir.NO_SPAN))
    spoken = sample(resolved, 4.0, seed=5, solver="cpsat")
    assert not isinstance(spoken, list)
    spoken = replace(spoken, extra={**spoken.extra, "utterances": [{**raw, "text": "I can't believe you did that"}]})
    before = sample(load("relief"), 3.0, seed=1)
    assert not isinstance(before, list)
    dialogue = before.then(spoken)  # the talking episode starts at 3 s, its utterance at 3.4 s
    assert dialogue.utterances[0]["start"] == 3.4
    assert check_dialogue(dialogue) == []
    gaze = next(s for s in dialogue.signals if s.episode == 1 and s.id == "gaze_away")
    late = [replace(s, start=s.start + 0.5) if s is gaze else s for s in dialogue.signals]  # 0.5 s after the turn
    violated = check_dialogue(replace(dialogue, signals=tuple(late)))
    assert [(v.episode, v.violation.constraint) for v in violated] == [(1, "away_at_turn")]


TALKING = Path(__file__).parent / "fixtures" / "speech" / "talking.xml"


@pytest.mark.parametrize("seed", range(12))
def test_a_dialogue_plans_anchors_with_what_was_said_and_commits_nothing_twice(seed: int) -> None:
    """An utterance during an episode whose set names the speech: the rest of the episode is
    planned again from the utterance with it (a new episode of the same emotion); what was
    committed before stays; every episode is consistent under the checker."""
    from mse.dialogue import Session
    from mse.dialogue.check import check_dialogue

    session = Session(seed=seed)
    before = session.emotion(0.0, str(TALKING), until=6.0)
    early = [s for s in session.timeline().signals]
    session.say(0.5, "I really cannot believe you did that", stress=["believe"])
    session.emotion(6.0, "relief", until=9.0)
    session.end(9.0)
    timeline = session.timeline()
    assert check_dialogue(timeline) == []
    episodes = timeline.extra["episodes"] if "episodes" in timeline.extra else timeline.to_json()["episodes"]
    assert [(e["start"], e["stop"]) for e in episodes] == [(0.0, 0.5), (0.5, 6.0), (6.0, 9.0)]
    assert episodes[0]["interrupted"] and episodes[1].get("continues")
    # committed before the utterance: unchanged (those of episode 0 that ended by 0.5)
    kept = {(s.id, s.start, s.stop) for s in timeline.signals if s.episode == 0}
    assert {(s.id, s.start, s.stop) for s in before if s.stop <= 0.5} <= kept
    assert all(s.episode != 0 or s.start < 0.5 for s in timeline.signals)
    del early


def test_a_dialogue_without_speech_leaves_anchored_constraints_out() -> None:
    from mse.dialogue import Session
    from mse.dialogue.check import check_dialogue

    session = Session(seed=1)
    session.emotion(0.0, str(TALKING), until=4.0)
    session.end(4.0)
    assert check_dialogue(session.timeline()) == []
