"""The greedy sampler: every timeline consistent, seeded, profiles followed, light imports."""

from __future__ import annotations

import json
import random
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mse.api as api
import mse.sampling as sampling
from mse.diagnostics import MseError
from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.prior_draw import prior_timeline
from mse.ir.schedule import Schedule, to_ticks
from mse.resources import bundled_names
from mse.solve.greedy.solver import GreedySolver
from mse.solve.greedy.walk import CAREFUL_DEBTS
from mse.solve.protocol import GreedyOptions, NoSolution, SolveRequest
from tests.strategies import models

REPO = Path(__file__).resolve().parent.parent
BUNDLED = bundled_names()
GRETA_EMOTIONS = (
    "anger", "anxiety", "embarrassment", "joy", "panic_fear", "pride", "regret", "rejoice", "relief", "tension",
)
_MODELS: dict[str, ir.Model] = {}


def bundled(name: str) -> ir.Model:
    if name not in _MODELS:
        _MODELS[name] = api.load(name)
    return _MODELS[name]


def solve(model: ir.Model, **fields: object) -> list[Schedule]:
    options = {key: fields.pop(key) for key in ("max_restarts", "slot") if key in fields}
    request = SolveRequest(**fields, greedy=GreedyOptions(**options))  # type: ignore[arg-type]
    return list(GreedySolver().solve(model, request).schedules)


def assert_consistent(model: ir.Model, schedule: Schedule) -> None:
    violations = check_schedule(model, schedule)
    assert not violations, [v.message for v in violations]


def signal(sid: str, **fields: object) -> ir.Signal:
    defaults: dict[str, object] = {"modality": "face", "lexeme": sid, "min_duration": 0.5, "max_duration": 1.0}
    defaults.update(fields)
    return ir.Signal(id=sid, **defaults)  # type: ignore[arg-type]


def xml_model(signals: str, constraints: str, name: str = "fixture") -> ir.Model:
    """A model from native XML fragments (``<signal .../>`` lines, ``<constraint>`` lines)."""
    text = (
        f'<?xml version="1.0" encoding="UTF-8"?>\n<expression name="{name}">\n'
        f"<signals>\n{signals}\n</signals>\n<constraints>\n{constraints}\n</constraints>\n</expression>\n"
    )
    return api.loads(text, path=f"{name}.xml")


# -- every timeline is consistent -------------------------------------------------------------------
@pytest.mark.skipif(not BUNDLED, reason="no bundled behaviour sets")
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(name=st.sampled_from(BUNDLED or ["none"]), seed=st.integers(0, 2**31), duration=st.integers(2000, 60000))
def test_bundled_sets_always_consistent(name: str, seed: int, duration: int) -> None:
    model = bundled(name)
    try:
        schedules = solve(model, duration=duration / 1000, seed=seed)
    except NoSolution:
        assert duration < 4000, "the bundled sets admit timelines of 4 s and more"
        return
    assert_consistent(model, schedules[0])


@pytest.mark.slow
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(model=models(max_signals=6), seed=st.integers(0, 2**31), duration=st.integers(2000, 60000))
def test_generated_sets_never_inconsistent(model: ir.Model, seed: int, duration: int) -> None:
    try:
        schedules = solve(model, duration=duration / 1000, seed=seed, count=2, max_restarts=10)
    except NoSolution as failure:
        assert not failure.proven
        assert failure.diagnostics
        return
    assert len(schedules) == 2
    for schedule in schedules:
        assert schedule.duration == duration
        assert_consistent(model, schedule)


def test_paper_worked_example() -> None:
    """``exists(a) and includes(a, b)``: whenever b occurs, a occurs and contains it."""
    model = xml_model(
        '<signal id="a" modality="head" min_duration="2" max_duration="4"/>\n'
        '<signal id="b" modality="face" min_duration="0.5" max_duration="1" probability_start="0.9"/>',
        '<constraint id="c">exists(a) and includes(a, b)</constraint>',
    )
    schedules = solve(model, duration=10, seed=3, count=40)
    with_b = 0
    for schedule in schedules:
        assert_consistent(model, schedule)
        by_signal = schedule.by_signal()
        if "b" in by_signal:
            with_b += 1
            (a,), (b,) = by_signal["a"], by_signal["b"]
            assert a.start <= b.start and b.stop <= a.stop
    assert with_b > 10


def test_equalities_and_offsets_met_exactly() -> None:
    model = xml_model(
        '<signal id="a" modality="head" min_duration="0.5" max_duration="1"/>\n'
        '<signal id="b" modality="face" min_duration="0.5" max_duration="1"/>\n'
        '<signal id="c" modality="gaze" min_duration="0.5" max_duration="1"/>',
        "<constraint id='pin'>start(b) = stop(a) + 0.2</constraint>\n"
        "<constraint id='late'>start(c) &gt; 2</constraint>\n"
        "<constraint id='needs'>exists(b) implies exists(a)</constraint>",
    )
    for schedule in solve(model, duration=6, seed=11, count=50):
        assert_consistent(model, schedule)
        by_signal = schedule.by_signal()
        if "b" in by_signal:
            assert by_signal["b"][0].start == by_signal["a"][0].stop + 200
        if "c" in by_signal:
            assert by_signal["c"][0].start > 2000


# -- Greta's ten emotions --------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def greta_models(greta_dir: Path) -> dict[str, ir.Model]:
    greta = pytest.importorskip("mse.syntax.greta")
    imported = greta.import_greta(greta_dir / "lexicon.xml", greta_dir / "constraint.xml")
    return {item.name: api.loads(item.xml) for item in imported}


@pytest.mark.parametrize("emotion", GRETA_EMOTIONS)
def test_greta_emotions_sample_consistently(greta_models: dict[str, ir.Model], emotion: str) -> None:
    model = greta_models[emotion]
    for duration in (4, 10, 30):
        for schedule in solve(model, duration=duration, seed=duration, count=3):
            assert_consistent(model, schedule)
    for schedule in solve(model, duration=10, seed=1, count=2, mode="constraint-less"):
        violations = check_schedule(model, schedule)
        assert violations and all(v.kind == "constraint" for v in violations)


# -- profiles, determinism, streaming ------------------------------------------------------------------
def _stamp_frequencies(model: ir.Model, runs: int) -> list[float]:
    """How often the first occurrence starts in each 1 s stamp of a 10 s timeline."""
    counts = [0] * 10
    for schedule in solve(model, duration=10, seed=5, count=runs):
        if schedule.occurrences:
            counts[schedule.occurrences[0].start // 1000] += 1
    return [c / runs for c in counts]


@pytest.mark.parametrize(("start", "end"), [(0.0, 0.6), (0.2, 0.8), (0.5, 0.5), (0.9, 0.1), (0.7, 0.0), (0.2, 0.2)])
def test_start_and_end_frequencies_follow_the_profile(start: float, end: float) -> None:
    """mse/ir/profile.py: a signal that occurs once occurs with probability (start + end) / 2
    and starts in second j with probability proportional to p at its middle, over the starts
    where its shortest length (0.5 s) fits: half of the last second."""
    model = ir.Model("one", (signal("x", probability_start=start, probability_end=end),))
    profile = [(start + (end - start) * (j + 0.5) / 10) * (0.5 if j == 9 else 1.0) for j in range(10)]
    occurs = (start + end) / 2
    expected = [occurs * p / sum(profile) for p in profile]
    observed = _stamp_frequencies(model, 2000)
    assert abs(observed[0] - expected[0]) < 0.03
    assert abs(observed[-1] - expected[-1]) < 0.03
    assert abs(sum(observed) - occurs) < 0.04
    if start == 0:
        assert observed[0] < 0.01
    if end == 0:
        assert observed[-1] < 0.01


def test_signals_with_both_probabilities_zero_never_occur() -> None:
    members = (signal("x", probability_start=0.0, probability_end=0.0, repetitivity=1),
               signal("y", probability_start=0.0, probability_end=0.0, modality="head"))
    for schedule in solve(ir.Model("zero", members), duration=30, seed=3, count=50):
        assert not schedule.occurrences


@pytest.mark.parametrize("probability", [0.0, 0.2, 0.5, 0.9])
def test_repetitive_signals_are_candidates_with_the_table_probability(probability: float) -> None:
    # Shorter than a stamp: free again at every stamp, so each stamp is one trial.
    model = ir.Model(
        "one", (signal("x", probability_start=probability, probability_end=probability, repetitivity=1,
                       max_duration=0.5),)
    )
    schedules = solve(model, duration=10, seed=9, count=400)
    first = sum(any(o.start < 1000 for o in s.occurrences) for s in schedules) / 400
    last = sum(any(o.start >= 9000 for o in s.occurrences) for s in schedules) / 400
    assert abs(first - probability) < 0.08
    # the last second: only its first half holds starts where the 0.5 s fits, and the signal
    # is not always free there: as often as in the prior's own draws (the reference sampler's)
    rng = random.Random(1)
    draws = [prior_timeline(model, 10_000, rng) for _ in range(4000)]
    wanted = sum(any(o.start >= 9000 for o in d.occurrences) for d in draws) / 4000
    assert abs(last - wanted) < 0.08


def test_long_timelines_spread_signals_over_the_span() -> None:
    members = tuple(signal(f"s{i}", modality=m) for i, m in enumerate(["face", "head", "gaze", "torso"]))
    schedules = solve(ir.Model("spread", members), duration=60, seed=2, count=100)
    starts = [o.start for s in schedules for o in s.occurrences]
    assert sum(1 for t in starts if t >= 30000) / len(starts) > 0.35


def test_profile_orders_signals_in_time() -> None:
    early = signal("early", probability_start=0.9, probability_end=0.0, modality="head")
    late = signal("late", probability_start=0.0, probability_end=0.9, modality="gaze")
    schedules = solve(ir.Model("profile", (early, late)), duration=10, seed=1, count=200)
    starts: dict[str, list[int]] = {"early": [], "late": []}
    for schedule in schedules:
        for occurrence in schedule.occurrences:
            starts[occurrence.signal].append(occurrence.start)
    assert sum(starts["early"]) / len(starts["early"]) < 3700  # density 0.9 -> 0: mean about 3.2 s
    assert sum(starts["late"]) / len(starts["late"]) > 6300  # mean about 6.8 s


@pytest.mark.skipif("embarrassment" not in BUNDLED, reason="bundled embarrassment missing")
def test_seeds_determine_output() -> None:
    model = bundled("embarrassment")
    first = solve(model, duration=10, seed=42, count=5)
    assert first == solve(model, duration=10, seed=42, count=5)
    # timeline i of --seed S --count N is timeline 0 of --seed S+i
    assert first[3] == solve(model, duration=10, seed=45)[0]
    assert len({s.occurrences for s in first}) > 1


@pytest.mark.skipif("embarrassment" not in BUNDLED, reason="bundled embarrassment missing")
def test_timelines_use_the_whole_span() -> None:
    model = bundled("embarrassment")
    schedules = solve(model, duration=10, seed=2, count=100)
    # the target (the prior conditioned on consistency, bench/evaluation/reference.py) has
    # 3.44 occurrences per timeline, and a start after 5 s in 86 % of the timelines (the walk:
    # 76 %, slightly under the target on this set: docs/sampler.md, "The walk's choices
    # against the target")
    assert sum(len(s.occurrences) for s in schedules) / 100 >= 3
    assert sum(max((o.start for o in s.occurrences), default=0) >= 5000 for s in schedules) / 100 > 0.7


@pytest.mark.skipif("anger" not in BUNDLED, reason="bundled anger missing")
def test_stream_yields_the_solved_timeline_in_start_order() -> None:
    model = bundled("anger")
    request = SolveRequest(duration=10, seed=8)
    streamed = list(GreedySolver().stream(model, request))
    assert streamed == sorted(streamed)
    assert tuple(sorted(streamed)) == tuple(sorted(GreedySolver().solve(model, request).schedules[0].occurrences))
    signals = list(sampling.iter_sample(model, 10, seed=8, solver="walk"))
    assert [s.id for s in signals] == [o.signal for o in streamed]


# -- control condition, require/forbid, failures ---------------------------------------------------------
@pytest.mark.skipif(not BUNDLED, reason="no bundled behaviour sets")
@pytest.mark.parametrize("name", BUNDLED)
def test_constraint_less_mode_always_violates_a_constraint(name: str) -> None:
    model = bundled(name)
    for schedule in solve(model, duration=10, seed=4, count=5, mode="constraint-less"):
        violations = check_schedule(model, schedule)
        assert violations
        assert all(v.kind == "constraint" for v in violations)


def test_constraint_less_mode_needs_constraints() -> None:
    model = ir.Model("bare", (signal("x"),))
    with pytest.raises(MseError, match="no constraints"):
        solve(model, duration=10, mode="constraint-less")


def test_require_and_forbid_are_honoured() -> None:
    model = ir.Model("rf", (signal("a", probability_start=0.1, probability_end=0.1), signal("b", modality="head")))
    for schedule in solve(model, duration=5, seed=1, count=20, require=("a",), forbid=("b",)):
        names = {o.signal for o in schedule.occurrences}
        assert "a" in names and "b" not in names
    with pytest.raises(MseError, match="unknown signal"):
        solve(model, duration=5, require=("zz",))


def test_impossible_obligation_fails_with_named_constraint() -> None:
    model = xml_model(
        '<signal id="a" modality="face" min_duration="5" max_duration="6"/>',
        '<constraint id="need_a">exists(a)</constraint>',
    )
    with pytest.raises(NoSolution) as caught:
        solve(model, duration=3, max_restarts=5)
    assert not caught.value.proven
    assert "need_a" in str(caught.value)


def test_bad_requests_are_user_errors() -> None:
    model = ir.Model("x", (signal("a"),))
    for fields in ({"duration": 0}, {"duration": 1, "slot": 0}, {"duration": 1, "mode": "odd"}):
        with pytest.raises(MseError):
            solve(model, **fields)


# -- the greedy path stays light ------------------------------------------------------------------------
HEAVY = ("ortools", "hmmlearn", "scipy", "sklearn")


def test_greedy_path_imports_nothing_heavy() -> None:
    code = (
        "import sys, json, mse.api as api, mse.sampling as sampling\n"
        "from mse.resources import bundled_names\n"
        "m = api.load('embarrassment') if bundled_names() else None\n"
        "if m is not None: list(sampling.iter_timelines(m, 10, seed=1, count=3))\n"
        f"print(json.dumps([n for n in {HEAVY!r} if n in sys.modules]))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, check=True)
    assert json.loads(result.stdout) == []


def test_cli_sample_imports_nothing_heavy() -> None:
    if not (REPO / "mse" / "cli" / "cmd_sample.py").exists():
        pytest.skip("mse sample not wired yet")
    code = (
        "import sys, json, contextlib, io\n"
        "from mse.cli import main\n"
        "out = io.StringIO()\n"
        "with contextlib.redirect_stdout(out):\n"
        "    code = main(['sample', '--duration', '10', '--seed', '1', '--format', 'json'])\n"
        f"print(json.dumps([code, [n for n in {HEAVY!r} if n in sys.modules]]))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO)
    assert result.returncode == 0, result.stderr
    code_returned, heavy = json.loads(result.stdout.strip().splitlines()[-1])
    assert heavy == []
    assert code_returned in (0, None)


def test_duration_ticks_are_exact() -> None:
    model = ir.Model("x", (signal("a"),))
    assert solve(model, duration=2.345, seed=1)[0].duration == to_ticks(2.345)


@pytest.mark.skipif(not BUNDLED, reason="no bundled behaviour sets")
@pytest.mark.parametrize("name", BUNDLED)
def test_starts_never_decrease_in_decision_order(name: str) -> None:
    """The paper's invariant: each placed signal starts no earlier than the previous one."""
    import random

    from mse.solve.greedy.engine import Attempt, Doomed
    from mse.solve.greedy.plan import plan_for
    from mse.solve.greedy.walk import OutOfBudget, walk

    plan = plan_for(bundled(name), 10_000, 1.0)
    rng = random.Random(7)
    for _ in range(30):
        try:
            occurrences = walk(Attempt(plan, rng, frozenset(), frozenset()), budget=5)
        except (Doomed, OutOfBudget):
            continue
        starts = [o.start for o in occurrences]
        assert starts == sorted(starts)


@pytest.mark.skipif("embarrassment" not in BUNDLED, reason="bundled embarrassment missing")
def test_output_is_identical_across_processes() -> None:
    """No dependence on string hashing (PYTHONHASHSEED) or anything but the seed."""
    import os

    code = (
        "import json, mse.api as api, mse.sampling as sampling\n"
        "t = sampling.iter_timelines(api.load('embarrassment'), 10, seed=3, count=20)\n"
        "print(json.dumps([x.to_json() for x in t]))\n"
    )
    outputs = []
    for hash_seed in ("1", "2"):
        env = {**os.environ, "PYTHONHASHSEED": hash_seed}
        result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, env=env,
                                check=True)
        outputs.append(result.stdout)
    assert outputs[0] == outputs[1]


def test_empty_timeline_debts_are_computed_once_per_plan_with_the_same_timelines() -> None:
    # relief --require relief_smile owes from the start: the first walk computes the debts of
    # the empty timeline, the next ones reuse them; a fresh model (a fresh plan) agrees.
    request = SolveRequest(duration=10, seed=3, count=5, require=("relief_smile",))
    first = GreedySolver().solve(api.load("relief"), request).schedules
    again = GreedySolver().solve(api.load("relief"), request).schedules
    assert first == again
    model = api.load("relief")
    one_by_one = [GreedySolver().solve(model, SolveRequest(duration=10, seed=3 + i, require=("relief_smile",)))
                  .schedules[0] for i in range(5)]
    assert one_by_one == list(first)


def test_open_stop_trial_agrees_with_every_stop_and_leaves_the_state_alone() -> None:
    import random

    from mse.solve.greedy.debts import Doomed
    from mse.solve.greedy.engine import Attempt
    from mse.solve.greedy.plan import plan_for

    def state(attempt: Attempt) -> tuple[object, ...]:
        return ({k: list(v) for k, v in attempt.env.items() if v}, attempt.frontier, set(attempt.owing),
                dict(attempt.latest), attempt.placements, dict(attempt.last_stop), dict(attempt.modality_free))

    refused = 0
    for name in ("relief", "tension", "anger", "cheerfulness", "embarrassment"):
        model = api.load(name)
        plan = plan_for(model, 10_000, 1.0)
        rng = random.Random(5)
        for _ in range(10):
            attempt = Attempt(plan, rng, frozenset(), frozenset())
            attempt.owing = set(plan.initial_owing)
            try:
                attempt.initial_debts()
            except Doomed:
                break
            for signal in rng.sample(list(plan.signals), len(plan.signals)):
                start = max(attempt.frontier, rng.randrange(0, 6000))
                low, high = start + signal.shortest, min(start + signal.longest, plan.duration)
                if low > high or not attempt.can_add(signal):
                    continue
                before = state(attempt)
                trial = attempt.open_stop_may_pay(signal, start, low, high)
                assert state(attempt) == before
                for stop in sorted({low, high, (low + high) // 2}):
                    saved = attempt._saved(signal)
                    if attempt.commit(signal, start, stop):
                        assert trial, (name, signal.id, start, stop)  # monotone: the trial allowed it
                        attempt._undo(signal, saved)
                    assert state(attempt) == before
                refused += not trial
                if rng.random() < 0.5:
                    attempt.commit(signal, start, high)  # keep some: later trials see a fuller state
    assert refused  # the trial does refuse sometimes


def test_prerequisites_by_halves_give_the_answer_of_every_cell(monkeypatch: pytest.MonkeyPatch) -> None:
    """The search of an owed signal's prerequisites skips the halves of starts whose relaxed
    box check fails: every answer is the one of probing every cell from the top."""
    import contextlib
    import random

    from mse.solve.greedy import obligations, windows
    from mse.solve.greedy.engine import Attempt
    from mse.solve.greedy.plan import plan_for
    from mse.solve.greedy.walk import OutOfBudget, walk

    def every_cell(check, low, high, points, box=None):  # type: ignore[no-untyped-def]
        return windows.latest_feasible(check, low, high, points)

    searched = [0, 0]
    halves = obligations.Obligations.prerequisites

    def both(self: Attempt, signal: object, low: int, high: int) -> object:
        found = halves(self, signal, low, high)  # type: ignore[arg-type]
        with monkeypatch.context() as patch:
            patch.setattr(obligations, "latest_feasible", every_cell)
            assert halves(self, signal, low, high) == found  # type: ignore[arg-type]
        searched[found is not None] += 1
        return found

    monkeypatch.setattr(obligations.Obligations, "prerequisites", both)
    cases = [("relief", ("relief_smile",)), ("cheerfulness", ("laugh",)), ("tension", ("pressed_lips",)),
             ("panic_fear", ("fear_face_lips_down",)), ("anger", ())]
    for name, require in cases:
        plan = plan_for(api.load(name), 10_000, 1.0)
        for seed in range(15):
            with contextlib.suppress(obligations.Doomed, OutOfBudget):
                walk(Attempt(plan, random.Random(seed), frozenset(), frozenset(require)), budget=5)
    assert searched[0] and searched[1]  # both outcomes were compared


# -- careful walks (docs/sampler.md, "Sixth pass") ----------------------------------------------
def _x_before_y(mandatory: int) -> list[bool]:
    """Per seed, whether ``x`` (always a candidate at once) starts before the ``y`` its
    implication owes, in a set whose empty timeline owes ``mandatory`` debts."""
    signals = "\n".join(
        [f'<signal id="m{i}" modality="m{i}" min_duration="0.5" max_duration="1"/>' for i in range(mandatory)]
        + ['<signal id="x" modality="head" min_duration="0.5" max_duration="1" probability_start="1" '
           'probability_end="1"/>',
           '<signal id="y" modality="gaze" min_duration="0.5" max_duration="1"/>']
    )
    constraints = "\n".join(
        [f'<constraint id="need_m{i}">exists(m{i})</constraint>' for i in range(mandatory)]
        + ['<constraint id="x_needs_y">exists(x) implies exists(y)</constraint>']
    )
    model = xml_model(signals, constraints)
    found = []
    for schedule in solve(model, duration=10, seed=1, count=40):
        assert_consistent(model, schedule)
        starts = {o.signal: o.start for o in schedule.occurrences}
        found.append("x" in starts and starts["x"] < starts.get("y", schedule.duration + 1))
    return found


def test_a_walk_owing_many_debts_from_the_start_is_careful() -> None:
    # careful: a placement that owes nothing may not add a debt (x owes y), so x only comes
    # once y is there; with fewer debts from the start the walk is the paper's, x first.
    assert not any(_x_before_y(CAREFUL_DEBTS))
    assert any(_x_before_y(CAREFUL_DEBTS - 1))


def test_planted_200_signal_sets_are_sampled_by_the_walk_alone() -> None:
    # The scale point of issue 12 (python -m bench.speed.sample --scale): before the careful
    # walk, the walk alone gave up on every seed of these two sets (an optional choice made
    # early left a required signal no room) and CP-SAT took over.
    from bench.generators.corpus import planted_model

    for k in (0, 2):
        model = planted_model(1000 * k + 600, 200, 400, 10.0)
        for schedule in solve(model, duration=10, seed=0, count=2):
            assert_consistent(model, schedule)
