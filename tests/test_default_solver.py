"""The default solver (walk -> CP-SAT -> proof, mse/solve/default.py) and what the walk gained
for it: prerequisites, backtracking, streaming commits, the probability definition."""

from __future__ import annotations

import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mse.api as api
import mse.sampling as sampling
from mse.cli import main
from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.schedule import Schedule
from mse.solve.default import DefaultSolver, _Run
from mse.solve.greedy.solver import GreedySolver, Tally
from mse.solve.protocol import NoSolution, Pin, SolveRequest, Status, get_solver
from tests.strategies import models

SEQ = """<?xml version="1.0" encoding="UTF-8"?>
<expression name="seq">
  <signals>
    <signal id="b" modality="face" lexeme="b"/>
    <signal id="c" modality="face" lexeme="c"/>
  </signals>
  <constraints>
    <constraint>exists(c)</constraint>
    <constraint>exists(b) and precedes(b, c)</constraint>
  </constraints>
</expression>
"""

CONFLICT = """<?xml version="1.0" encoding="UTF-8"?>
<expression name="conflict">
  <signals>
    <signal id="a" modality="face" lexeme="a" min_duration="1" max_duration="2"/>
    <signal id="b" modality="head" lexeme="b" min_duration="1" max_duration="2"/>
    <signal id="c" modality="gaze" lexeme="c"/>
  </signals>
  <constraints>
    <constraint id="need_a">exists(a)</constraint>
    <constraint id="b_first">exists(b) and precedes(b, a)</constraint>
    <constraint id="a_first">precedes(a, b)</constraint>
  </constraints>
</expression>
"""


def consistent(model: ir.Model, schedule: Schedule) -> bool:
    return not check_schedule(model, schedule)


def test_a_signal_needing_another_before_it_is_sampled_by_the_walk() -> None:
    """docs/behaviour_sets.md's idiom: c is mandatory and needs b before it."""
    model = api.loads(SEQ, path="seq.xml")
    walk = GreedySolver()
    for schedule in walk.solve(model, SolveRequest(duration=10, seed=1, count=30)).schedules:
        assert consistent(model, schedule)
        b, c = (next(o for o in schedule.occurrences if o.signal == name) for name in "bc")
        assert b.stop <= c.start


@pytest.mark.parametrize(("name", "signal"), [
    ("relief", "relief_smile"), ("cheerfulness", "laugh"), ("panic_fear", "fear_face_lips_down"),
    ("tension", "pressed_lips"), ("tension", "lip_bite"),
])
def test_required_signals_with_prerequisites_are_sampled_by_the_walk(name: str, signal: str) -> None:
    model = api.load(name)
    request = SolveRequest(duration=10, seed=3, count=10, require=(signal,))
    for schedule in GreedySolver().solve(model, request).schedules:
        assert consistent(model, schedule)
        assert signal in {o.signal for o in schedule.occurrences}


def test_timeline_json_records_method_and_mode() -> None:
    model = api.load("embarrassment")
    timeline = sampling.sample(model, 10, seed=2)
    assert not isinstance(timeline, list)
    obj = timeline.to_json()
    assert obj["method"] == "rejection" and obj["mode"] == "consistent" and obj["solver"] == "greedy"
    free = sampling.sample(model, 10, seed=2, mode="constraint-less")
    assert not isinstance(free, list)
    assert free.to_json()["mode"] == "constraint-less"


def test_table_header_names_mode_and_method(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sample", "embarrassment", "--seed", "1", "--format", "table", "--mode", "constraint-less"]) == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert "mode constraint-less" in header and "method walk" in header


def test_no_timeline_is_proven_with_the_conflicting_lines() -> None:
    model = api.loads(CONFLICT, path="conflict.xml")
    with pytest.raises(NoSolution) as caught:
        DefaultSolver().solve(model, SolveRequest(duration=10, seed=1))
    assert caught.value.proven
    text = caught.value.reason
    for name, line in (("need_a", 9), ("b_first", 10), ("a_first", 11)):
        assert f"{name} (conflict.xml:{line})" in text


def test_pins_go_to_the_complete_solver() -> None:
    model = api.load("relief")
    result = DefaultSolver().solve(model, SolveRequest(duration=10, seed=1, pinned=(Pin("open_mouth", 1.0, 3.0),)))
    [schedule] = result.schedules
    assert result.status is Status.FEASIBLE and result.methods == ("cpsat",)
    assert consistent(model, schedule)
    assert any(o.signal == "open_mouth" and (o.start, o.stop) == (1000, 3000) for o in schedule.occurrences)


def test_never_occurring_signals_occur_only_when_a_constraint_demands_them() -> None:
    quiet = ir.Signal("q", "face", "q", 0.5, 1.0, probability_start=0.0, probability_end=0.0)
    loud = ir.Signal("l", "head", "l", 0.5, 1.0)
    alone = ir.Model("zero", (quiet, loud))
    for schedule in DefaultSolver().solve(alone, SolveRequest(duration=5, seed=1, count=20)).schedules:
        assert "q" not in {o.signal for o in schedule.occurrences}
    needed = ir.Model("zero", (quiet, loud), (ir.Constraint("c1", ir.Exists("q")),))
    solver = DefaultSolver()
    [schedule] = solver.solve(needed, SolveRequest(duration=5, seed=1)).schedules
    assert "q" in {o.signal for o in schedule.occurrences} and consistent(needed, schedule)


def test_what_one_solve_learns_of_the_never_occurring_signals_holds_for_every_seed(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # c1 demands q (probabilities 0/0): the pass without q is proven impossible once, and
    # CP-SAT asked once whether a timeline exists with q; the walk makes every timeline.
    quiet = ir.Signal("q", "face", "q", 0.5, 1.0, probability_start=0.0, probability_end=0.0)
    loud = ir.Signal("l", "head", "l", 0.5, 1.0)
    needed = ir.Model("zero", (quiet, loud), (ir.Constraint("c1", ir.Exists("q")),))
    calls: list[int] = []
    complete = _Run._complete

    def counted(run: _Run, request: SolveRequest, seed: int) -> Schedule:
        calls.append(seed)
        return complete(run, request, seed)

    monkeypatch.setattr(_Run, "_complete", counted)
    result = DefaultSolver().solve(needed, SolveRequest(duration=5, seed=1, count=6))
    schedules = result.schedules
    assert len(calls) == 2  # the proof without q (seed 1), the existence check with q
    # (rejection never accepts a draw: a constraint demands q, which the prior never draws,
    # so the chain follows the walk; its moves of q are never consistent)
    assert result.methods == ("walk+chain",) * 6
    assert all("q" in {o.signal for o in s.occurrences} and consistent(needed, s) for s in schedules)
    # the same timelines as one seed at a time
    for index, schedule in enumerate(schedules):
        assert DefaultSolver().solve(needed, SolveRequest(duration=5, seed=1 + index)).schedules[0] == schedule


def test_no_timeline_even_with_the_never_occurring_signals_is_proven_without_a_second_walk(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    quiet = ir.Signal("q", "face", "q", 0.5, 1.0, probability_start=0.0, probability_end=0.0)
    loud = ir.Signal("l", "head", "l", 0.5, 1.0)
    model = ir.Model("zero", (quiet, loud), (
        ir.Constraint("c1", ir.Exists("q")), ir.Constraint("c2", ir.Not(ir.Exists("q"))),
    ))
    solver = DefaultSolver()
    walks: list[int] = []
    walk = GreedySolver.one

    def counted(self: GreedySolver, model: ir.Model, request: SolveRequest, seed: int, tally: Tally) -> Schedule:
        walks.append(seed)
        return walk(self, model, request, seed, tally)

    monkeypatch.setattr(GreedySolver, "one", counted)
    with pytest.raises(NoSolution) as caught:
        solver.solve(model, SolveRequest(duration=5, seed=1))
    assert caught.value.proven and "c1" in caught.value.reason and "c2" in caught.value.reason
    assert len(walks) == 1


def test_stream_hands_out_occurrences_before_the_walk_ends(monkeypatch: pytest.MonkeyPatch) -> None:
    """Streaming commits at settled stamps: the first occurrences come long before the end."""
    import mse.solve.greedy.walk as walk_module

    walked: list[int] = []
    original = walk_module.walk_stamp

    def counting(attempt: object, j: int) -> None:
        walked.append(j)
        original(attempt, j)  # type: ignore[arg-type]

    monkeypatch.setattr(walk_module, "walk_stamp", counting)
    model = api.load("tension")
    # (the walk's stream: the rejection stage would hand the whole timeline out at once)
    stream = get_solver("greedy").stream(model, SolveRequest(duration=600, seed=5, rejection=False))
    first = next(iter(stream))
    assert first.start < 60_000
    assert max(walked) < 300  # not decided to the end yet
    rest = list(stream)
    schedule = Schedule.of(600_000, [first, *rest])
    assert consistent(model, schedule)
    assert [o.start for o in [first, *rest]] == sorted(o.start for o in [first, *rest])


def test_streamed_and_solved_timelines_are_both_consistent() -> None:
    model = api.load("embarrassment")
    for seed in range(5):
        streamed = list(get_solver("greedy").stream(model, SolveRequest(duration=60, seed=seed)))
        assert consistent(model, Schedule.of(60_000, streamed))


def test_long_timelines_keep_repetitive_signals_going() -> None:
    """A repetitive signal starts at p per free second all along a long timeline."""
    signal = ir.Signal("r", "face", "r", 1.0, 1.0, probability_start=0.5, probability_end=0.5, repetitivity=1)
    [schedule] = GreedySolver().solve(ir.Model("rep", (signal,)), SolveRequest(duration=600, seed=2)).schedules
    starts = [o.start for o in schedule.occurrences]
    # free 1 s after each 1 s occurrence, then a start within about 1 / 0.5 s on average: ~3 s apart
    assert 150 < len(starts) < 300
    assert sum(1 for s in starts if s >= 300_000) > 0.4 * len(starts)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(model=models(max_signals=5, max_constraints=5), seed=st.integers(0, 2**20),
       duration=st.sampled_from([3.0, 6.0, 10.0]))
def test_whenever_cpsat_finds_a_timeline_the_default_solver_returns_one(
    model: ir.Model, seed: int, duration: float
) -> None:
    request = SolveRequest(duration=duration, seed=seed, time_limit=5.0)
    try:
        get_solver("cpsat").solve(model, request)
    except NoSolution:
        return
    result = DefaultSolver().solve(model, request)
    [schedule] = result.schedules
    assert consistent(model, schedule)
    assert result.methods[0] in ("rejection", "walk", "cpsat", "walk+chain", "cpsat+chain")


def test_cli_json_carries_the_method(capsys: pytest.CaptureFixture[str], tmp_path: object) -> None:
    from pathlib import Path

    path = Path(str(tmp_path)) / "seq.xml"
    path.write_text(SEQ, encoding="utf-8")
    assert main(["sample", str(path), "--seed", "4", "--format", "json"]) == 0
    assert json.loads(capsys.readouterr().out)["method"] in ("rejection", "walk", "walk+chain")


def test_a_loop_of_one_solve_per_seed_gives_the_count_run_and_validates_each_request() -> None:
    """The solver keeps nothing between solves: a loop of one solve() per seed gives the
    timelines of a --count run, and every request is checked."""
    model = api.load("relief")
    solver = DefaultSolver()
    counted = solver.solve(model, SolveRequest(duration=10.0, seed=5, count=4)).schedules
    one_by_one = tuple(solver.solve(model, SolveRequest(duration=10.0, seed=5 + i)).schedules[0] for i in range(4))
    assert [s.occurrences for s in one_by_one] == [s.occurrences for s in counted]
    forbidden = model.signals[0].id
    for schedule in (solver.solve(model, SolveRequest(duration=10.0, seed=s, forbid=(forbidden,))).schedules[0]
                     for s in range(3)):
        assert all(o.signal != forbidden for o in schedule.occurrences)
    with pytest.raises(Exception, match="unknown signal"):
        solver.solve(model, SolveRequest(duration=10.0, seed=9, forbid=("no_such_signal",)))
