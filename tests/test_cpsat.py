"""CP-SAT backend: exact timelines, pins, require/forbid, objectives, diversity, proofs."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from mse.api import load, loads
from mse.diagnostics import MseError
from mse.ir.evaluate import check_schedule
from mse.ir.schedule import to_ticks
from mse.resources import bundled_names
from mse.sampling import explain, iter_timelines, sample
from mse.solve.cpsat.solver import CpSatSolver
from mse.solve.protocol import NoSolution, Pin, SolveRequest
from mse.timeline import Timeline

FIXTURES = Path(__file__).parent / "fixtures" / "solvers"
TINY = FIXTURES / "tiny.xml"
CONFLICT = FIXTURES / "conflict.xml"



def _consistent(model_path: Path | str, timeline: Timeline) -> None:
    model = load(model_path)
    assert check_schedule(model, timeline.to_schedule()) == []


def test_tiny_timelines_are_consistent_and_vary_with_the_seed() -> None:
    model = load(TINY)
    timelines = [sample(model, 4.0, seed=seed, solver="cpsat") for seed in range(6)]
    for timeline in timelines:
        assert timeline.solver == "cpsat"
        _consistent(TINY, timeline)
    assert len({t.dumps(indent=None).split('"signals"')[1] for t in timelines}) > 1


def test_same_seed_same_timeline() -> None:
    model = load(TINY)
    first = sample(model, 4.0, seed=11, solver="cpsat")
    second = sample(model, 4.0, seed=11, solver="cpsat")
    assert first.signals == second.signals


@pytest.mark.parametrize("name", bundled_names())
def test_every_bundled_set_samples_at_10_seconds(name: str) -> None:
    model = load(name)
    timeline = sample(model, 10.0, seed=1, solver="cpsat")
    _consistent(name, timeline)


def test_pin_require_forbid() -> None:
    model = load(TINY)
    pinned = (Pin("look_down", 0.5, 1.5),)
    for seed in range(3):
        timeline = sample(model, 4.0, seed=seed, solver="cpsat", pinned=pinned,
                          require=("nod",), forbid=("look_away",))
        ids = [s.id for s in timeline.signals]
        assert ("look_down", 0.5, 1.5) in [(s.id, s.start, s.stop) for s in timeline.signals]
        assert "nod" in ids and "look_away" not in ids
        _consistent(TINY, timeline)


def test_require_a_signal_that_needs_another() -> None:
    # nod_in_smile: nod needs smile around it, and smile needs look_down.
    model = load(TINY)
    timeline = sample(model, 4.0, seed=2, solver="cpsat", require=("nod",))
    ids = {s.id for s in timeline.signals}
    assert {"smile", "nod", "look_down"} <= ids
    _consistent(TINY, timeline)


def test_unknown_signal_and_bad_pin_are_argument_errors() -> None:
    model = load(TINY)
    with pytest.raises(MseError, match="unknown signal 'frown'"):
        sample(model, 4.0, seed=0, solver="cpsat", require=("frown",))
    with pytest.raises(MseError, match="not inside"):
        sample(model, 4.0, seed=0, solver="cpsat", pinned=(Pin("nod", 3.5, 5.0),))


@pytest.mark.parametrize("objective", ["likely", "random", "most-signals", "fewest-signals"])
def test_objectives(objective: str) -> None:
    model = load(TINY)
    timeline = sample(model, 4.0, seed=3, solver="cpsat", objective=objective)
    _consistent(TINY, timeline)
    ids = {s.id for s in timeline.signals}
    if objective == "most-signals":
        assert ids == {"look_down", "look_away", "smile", "nod"}
    if objective == "fewest-signals":
        assert ids == set()


def test_likely_is_deterministic_across_seeds() -> None:
    model = load(TINY)
    first = sample(model, 4.0, seed=1, solver="cpsat", objective="likely")
    second = sample(model, 4.0, seed=2, solver="cpsat", objective="likely")
    assert [s.id for s in first.signals] == [s.id for s in second.signals]


def test_diverse_timelines_differ() -> None:
    model = load(TINY)
    timelines = list(iter_timelines(model, 4.0, seed=5, count=3, solver="cpsat", diverse=True))
    assert len(timelines) == 3
    keys = {tuple((s.id, s.start, s.stop) for s in t.signals) for t in timelines}
    assert len(keys) == 3
    for timeline in timelines:
        _consistent(TINY, timeline)
    assert [t.seed for t in timelines] == [5, 6, 7]
    again = list(iter_timelines(model, 4.0, seed=5, count=3, solver="cpsat", diverse=True))
    assert [t.signals for t in again] == [t.signals for t in timelines]


def test_count_without_diverse_reproduces_single_seeds() -> None:
    model = load(TINY)
    many = list(iter_timelines(model, 4.0, seed=20, count=2, solver="cpsat"))
    alone = sample(model, 4.0, seed=21, solver="cpsat")
    assert many[1].signals == alone.signals


def test_infeasible_is_proven_and_explained() -> None:
    model = load(CONFLICT)
    with pytest.raises(NoSolution) as caught:
        sample(model, 2.0, seed=0, solver="cpsat")
    assert caught.value.proven
    message = str(caught.value)
    assert "no timeline of 2 s" in message
    assert "needs_a (" in message and "b_after_a (" in message
    assert "conflict.xml:10" in message
    # The same file has timelines when there is room.
    _consistent(CONFLICT, sample(model, 4.0, seed=0, solver="cpsat"))


def test_explanation_is_minimal() -> None:
    model = load(CONFLICT)
    explanation = explain(model, 2.0)
    assert explanation is not None and explanation.minimal and explanation.proven
    kinds = {(item.id, item.kind) for item in explanation.items}
    assert kinds == {("a", "duration"), ("b", "duration"), ("needs_a", "constraint"),
                     ("b_after_a", "constraint")}
    assert explanation.render().startswith("no timeline of 2 s: a [duration] (")
    assert explain(model, 10.0) is None


def test_explanation_blames_pins_and_forbid() -> None:
    model = load(TINY)
    explanation = explain(model, 4.0, pinned=(Pin("nod", 0.0, 1.0),), forbid=("smile",))
    assert explanation is not None
    assert {item.kind for item in explanation.items} == {"pin", "forbid", "constraint"}
    assert [i.id for i in explanation.items if i.kind == "constraint"] == ["nod_in_smile"]


def test_occurrence_rule_in_explanation() -> None:
    xml = """<?xml version="1.0"?>
<expression name="two_gazes">
  <modality name="gaze" exclusive="true"/>
  <signals>
    <signal id="up" modality="gaze" min_duration="1"/>
    <signal id="down" modality="gaze" min_duration="1"/>
  </signals>
  <constraints>
    <constraint id="both">exists(up) and exists(down)</constraint>
    <constraint id="same_time">start(up) = start(down)</constraint>
  </constraints>
</expression>"""
    model = loads(xml, path="two_gazes.xml")
    explanation = explain(model, 10.0)
    assert explanation is not None
    assert {(i.id, i.kind) for i in explanation.items} == {
        ("gaze", "occurrence rule"), ("both", "constraint"), ("same_time", "constraint")}


def test_time_limit_is_not_a_proof() -> None:
    # Pigeonholes: 12 required one-second signals, pairwise disjoint, in 11.9 s.
    count = 12
    signals = "".join(f'<signal id="g{i}" modality="face" min_duration="1"/>' for i in range(count))
    constraints = "".join(f"<constraint>exists(g{i})</constraint>" for i in range(count))
    constraints += "".join(f"<constraint>excludes(g{i}, g{j})</constraint>"
                           for i in range(count) for j in range(i + 1, count))
    xml = (f'<expression name="crowded">'
           f"<signals>{signals}</signals><constraints>{constraints}</constraints></expression>")
    model = loads(xml, path="crowded.xml")
    with pytest.raises(NoSolution) as caught:
        CpSatSolver().solve(model, SolveRequest(duration=11.9, time_limit=0.05))
    assert not caught.value.proven
    assert "not a proof" in str(caught.value)


def test_repetitive_signal_can_recur_and_proof_uses_enough_slots() -> None:
    # Needs two occurrences of s: one before 1 s and one after 3 s (each false atom has
    # its own witness occurrence).
    xml = """<?xml version="1.0"?>
<expression name="twice">
  <signals><signal id="s" modality="face" min_duration="0.5" max_duration="1" repetitivity="1"/></signals>
  <constraints>
    <constraint id="early">exists(s) and not (start(s) &gt;= 1)</constraint>
    <constraint id="late">not (start(s) &lt;= 3)</constraint>
  </constraints>
</expression>"""
    model = loads(xml, path="twice.xml")
    timeline = sample(model, 5.0, seed=0, solver="cpsat", objective="fewest-signals", require=("s",))
    assert len(timeline.signals) >= 2
    assert check_schedule(model, timeline.to_schedule()) == []


def test_constraint_less_mode_ignores_constraints() -> None:
    model = load(CONFLICT)
    timeline = sample(model, 2.0, seed=0, solver="cpsat", mode="constraint-less", require=("a", "b"))
    starts = {s.id: (to_ticks(s.start), to_ticks(s.stop)) for s in timeline.signals}
    assert {"a", "b"} <= set(starts)


def test_importing_mse_does_not_load_solvers() -> None:
    code = ("import sys, mse, mse.api, mse.solve.cpsat, mse.solve.csp, mse.solve.cpsat.explain, "
            "mse.solve.cpsat.deep_lint; "
            "assert 'ortools' not in sys.modules and 'constraint' not in sys.modules, "
            "[m for m in sys.modules if m.startswith(('ortools', 'constraint'))]")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_signal_longer_than_the_timeline_is_blamed_on_its_duration() -> None:
    model = load(CONFLICT)
    explanation = explain(model, 1.0)
    assert explanation is not None
    assert {(i.id, i.kind) for i in explanation.items} == {("a", "duration"), ("needs_a", "constraint")}


def test_perturb_and_map_follows_the_probability_profiles() -> None:
    xml = """<expression name="profiles"><signals>
<signal id="often" modality="face" min_duration="0.5" max_duration="1" probability_start="0.8" probability_end="0.8"/>
<signal id="early" modality="head" min_duration="0.5" max_duration="1" probability_start="0.9" probability_end="0.1"/>
<signal id="rare" modality="gaze" min_duration="0.5" max_duration="1" probability_start="0.2" probability_end="0.2"/>
</signals></expression>"""
    model = loads(xml)
    runs = 150
    present = {"often": 0, "early": 0, "rare": 0}
    in_first_half = 0
    for seed in range(runs):
        (schedule,) = CpSatSolver().solve(model, SolveRequest(duration=10.0, seed=seed)).schedules
        for occurrence in schedule.occurrences:
            present[occurrence.signal] += 1
            in_first_half += occurrence.signal == "early" and occurrence.start < 5000
    # Expected presence: the mean of each profile (0.8, 0.5, 0.2); "early" starts in the
    # first half with probability 0.35 / 0.5 = 0.7.
    assert abs(present["often"] / runs - 0.8) < 0.12
    assert abs(present["early"] / runs - 0.5) < 0.14
    assert abs(present["rare"] / runs - 0.2) < 0.12
    assert in_first_half / max(1, present["early"]) > 0.55
