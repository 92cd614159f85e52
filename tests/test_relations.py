"""One table of relations (mse/ir/relations.py): every consumer reads it.

So a relation added to the table is evaluated, checked fast, sampled (masks, folds and
generated checks), bounded (edges, start bounds), solved by CP-SAT and mined with no other
edit.  Two relations that exist only in these tests show it: a conjunction (``a`` stops
where ``b`` starts) and a disjunction that is not "no overlap" (``a`` starts or stops
strictly before ``b``), which takes the pair-by-pair paths.
"""

from __future__ import annotations

import random
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace

import pytest

from mse.ir import model as ir
from mse.ir.evaluate import _all_violations, check_schedule, evaluate_atom, evaluate_expr, is_clean
from mse.ir.evaluate.semantics import relation_holds
from mse.ir.relations import (
    RELATIONS,
    STRICT,
    Bound,
    Endpoint,
    Meaning,
    describe,
    is_conjunction,
    is_disjointness,
    is_symmetric,
)
from mse.ir.schedule import Occurrence, Schedule
from mse.learn import read_corpus
from mse.learn.mine import MiningOptions, mine
from mse.learn.stats import corpus_arrays
from mse.solve.cpsat.solver import CpSatSolver
from mse.solve.greedy.closures import compile_expr
from mse.solve.greedy.closures import generated as _generated
from mse.solve.greedy.edges import _comparisons, start_bounds_of
from mse.solve.greedy.masks import F, N, T, fold_relation, relation_mask
from mse.solve.greedy.partial import CompiledConstraint
from mse.solve.greedy.solver import GreedySolver
from mse.solve.protocol import SolveRequest

DOCS = Path(__file__).resolve().parent.parent / "docs" / "semantics.md"
A_START, A_STOP = Endpoint("left", "start"), Endpoint("left", "stop")
B_START, B_STOP = Endpoint("right", "start"), Endpoint("right", "stop")

MEETS = "test_meets"  # a.stop = b.start
LEADS = "test_leads"  # a.start < b.start or a.stop < b.stop
ADDED = {
    MEETS: Meaning((Bound(A_STOP, B_START), Bound(B_START, A_STOP))),
    LEADS: Meaning((Bound(A_START, B_START, STRICT), Bound(A_STOP, B_STOP, STRICT)), "or"),
}


def _by_hand(kind: str, a: tuple[int, int], b: tuple[int, int]) -> bool:
    """The relations as docs/semantics.md defines them, written out (the oracle)."""
    return {
        "includes": a[0] <= b[0] and b[1] <= a[1],
        "excludes": a[1] <= b[0] or b[1] <= a[0],
        "precedes": a[1] <= b[0],
        "rightincludes": a[0] <= b[1] <= a[1],
        MEETS: a[1] == b[0],
        LEADS: a[0] < b[0] or a[1] < b[1],
    }[kind]


@pytest.fixture
def added(monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[str, ...]]:
    for kind, meaning in ADDED.items():
        monkeypatch.setitem(RELATIONS, kind, meaning)
    yield tuple(ADDED)


def _intervals(rng: random.Random) -> tuple[int, int]:
    start = rng.randrange(0, 12)
    return start, start + rng.randrange(1, 6)


def test_the_docs_list_what_the_table_says() -> None:
    text = DOCS.read_text(encoding="utf-8")
    for row in describe():
        assert row in text


def test_the_table_says_what_the_docs_define() -> None:
    rng = random.Random(3)
    for _ in range(2000):
        a, b = _intervals(rng), _intervals(rng)
        for kind in ("includes", "excludes", "precedes", "rightincludes"):
            assert relation_holds(kind, a, b) == _by_hand(kind, a, b)
    assert is_symmetric(RELATIONS["excludes"]) and is_disjointness(RELATIONS["excludes"])
    assert not any(is_symmetric(RELATIONS[k]) for k in ("includes", "precedes", "rightincludes"))
    assert all(is_conjunction(RELATIONS[k]) for k in ("includes", "precedes", "rightincludes"))


def test_an_added_relation_is_evaluated(added: tuple[str, ...]) -> None:
    rng = random.Random(5)
    for kind in added:
        for _ in range(500):
            pools = {"a": [_intervals(rng)], "b": [_intervals(rng), (20, 22)][: rng.randrange(1, 3)]}
            expected = all(_by_hand(kind, x, y) for x in pools["a"] for y in pools["b"])
            assert evaluate_atom(ir.Relation(kind, "a", "b"), pools, 30) is expected  # type: ignore[arg-type]
        assert evaluate_atom(ir.Relation(kind, "a", "b"), {"a": [(0, 5)]}, 30) is None  # type: ignore[arg-type]
    assert relation_holds(MEETS, (0, 5), (5, 9)) and not relation_holds(MEETS, (0, 5), (6, 9))


def _model(expr: ir.Expr, repetitive: bool = False) -> ir.Model:
    signals = tuple(
        ir.Signal(name, modality, name, min_duration=0.5, max_duration=3.0, repetitivity=int(repetitive),
                  max_occurrences=3 if repetitive else None)
        for name, modality in (("a", "face"), ("b", "head"), ("c", "gaze"))
    )
    return ir.Model("added", signals, (ir.Constraint("c1", expr, text="added"),))


def _exprs(kinds: tuple[str, ...]) -> list[ir.Expr]:
    meets, leads = (ir.Relation(k, "a", "b") for k in kinds)  # type: ignore[arg-type]
    return [
        ir.And((ir.Exists("a"), ir.Exists("b"), meets)),
        ir.And((ir.Exists("a"), ir.Exists("b"), leads)),
        ir.Or((meets, ir.Relation(kinds[1], "b", "c"))),  # type: ignore[arg-type]
        ir.Not(leads),
        ir.Implies(ir.Exists("c"), ir.And((meets, ir.Relation(kinds[0], "a", "a")))),  # type: ignore[arg-type]
    ]


def test_the_fast_checker_agrees_with_the_evaluator(added: tuple[str, ...]) -> None:
    rng = random.Random(7)
    for expr in _exprs(added):
        model = _model(expr, repetitive=True)
        for _ in range(300):
            occurrences = []
            for name in rng.sample("abc", rng.randrange(0, 4)):
                for count in range(rng.randrange(1, 3)):
                    start = rng.randrange(0, 8) * 500 + 4000 * count
                    occurrences.append(Occurrence(start, start + rng.randrange(1, 6) * 500, name))
            schedule = Schedule(10_000, tuple(occurrences))
            assert is_clean(model, schedule) == (not _all_violations(model, schedule))


def _boxes(rng: random.Random, count: int) -> list[tuple[int, int, int, int]]:
    """Occurrence boxes of one signal as the walk has them: in order, never overlapping, the
    last perhaps a range."""
    found, time = [], 0
    for index in range(count):
        start = time + rng.randrange(0, 4)
        stop = start + rng.randrange(1, 4)
        if index == count - 1 and rng.random() < 0.5:
            found.append((start, start + rng.randrange(0, 3), stop + 2, stop + 2 + rng.randrange(0, 3)))
        else:
            found.append((start, start, stop, stop))
        time = stop + 2
    return found


def _points(box: tuple[int, int, int, int]) -> Iterator[tuple[int, int]]:
    for start in range(box[0], box[1] + 1):
        for stop in range(box[2], box[3] + 1):
            if start < stop:
                yield start, stop


def test_the_walk_masks_folds_and_generated_checks_read_it(added: tuple[str, ...]) -> None:
    rng = random.Random(11)
    for kind in added:
        for _ in range(400):
            lefts, rights = _boxes(rng, rng.randrange(1, 4)), _boxes(rng, rng.randrange(1, 4))
            a, b = lefts[0], rights[0]
            possible = {_by_hand(kind, x, y) for x in _points(a) for y in _points(b)}
            mask = relation_mask(kind, a, b)
            assert (T if True in possible else 0) | (F if False in possible else 0) == mask & (T | F)
            if all(box[0] == box[1] and box[2] == box[3] for box in lefts + rights):
                value = all(_by_hand(kind, (x[0], x[2]), (y[0], y[2])) for x in lefts for y in rights)
                assert fold_relation(kind, lefts, rights) == (T if value else F)
            expected = T if all(relation_mask(kind, x, y) & T for x in lefts for y in rights) else 0
            assert fold_relation(kind, lefts, rights) & T == expected
    for expr in _exprs(added):
        closure, generated = compile_expr(expr, 10), _generated(expr, None, 10)
        for _ in range(300):
            env = {name: _boxes(rng, rng.randrange(1, 3)) for name in rng.sample("abc", rng.randrange(0, 4))}
            assert generated(env) == closure(env)
            points = {k: v for k, v in env.items() if all(x[0] == x[1] and x[2] == x[3] for x in v)}
            if len(points) == len(env):
                intervals = {k: [(x[0], x[2]) for x in v] for k, v in env.items()}
                truth = evaluate_expr(expr, intervals, 10)
                assert closure(env) == {True: T, False: F, None: N}[truth]  # type: ignore[index]


@pytest.mark.parametrize("solver", [GreedySolver, CpSatSolver])
def test_the_solvers_sample_it(added: tuple[str, ...], solver: type) -> None:
    for expr in [*_exprs(added)[:2], ir.And((ir.Exists("a"), ir.Exists("b"), _exprs(added)[3]))]:
        model = _model(expr)
        # a and b required: the constraint counts only when they occur, and the walk now keeps
        # an optional a whose partner must start at its very stop only as rarely as the prior
        # would (docs/sampler.md, "Placing one candidate", step 7)
        request = SolveRequest(duration=10, seed=3, count=3, require=("a", "b"))
        schedules = solver().solve(model, request).schedules
        for schedule in schedules:
            assert check_schedule(model, schedule) == []
            assert evaluate_expr(expr, {o.signal: [(o.start, o.stop)] for o in schedule.occurrences}, 10_000)


def test_the_edges_and_start_bounds_read_it(added: tuple[str, ...]) -> None:
    meets = ir.Relation(MEETS, "a", "b")  # type: ignore[arg-type]
    assert _comparisons(meets, 0) == [(ir.SignalTime("a", "stop"), ir.SignalTime("b", "start"), 0),
                                      (ir.SignalTime("b", "start"), ir.SignalTime("a", "stop"), 0)]
    constraint = CompiledConstraint(ir.Constraint("c1", meets), 10_000)
    b = SimpleNamespace(id="b", shortest=100, longest=1000)
    # b.start >= a.stop and b.start <= a.stop
    assert {(s.other, s.box_index, s.delta, s.upper) for s in start_bounds_of(b, [constraint], 10_000)} == {
        ("a", 2, 0, False), ("a", 2, 0, True)}
    # test_leads(a, b) once b is placed (and started no later than a): a must stop first
    leads = CompiledConstraint(ir.Constraint("c2", ir.Relation(LEADS, "a", "b")), 10_000)  # type: ignore[arg-type]
    a = SimpleNamespace(id="a", shortest=100, longest=1000)
    assert [(s.other, s.box_index, s.delta, s.upper) for s in start_bounds_of(a, [leads], 10_000)] == [
        ("b", 2, -101, True)]
    assert start_bounds_of(b, [leads], 10_000) == ()  # either bound may hold


def test_the_miner_finds_it(added: tuple[str, ...], tmp_path: Path) -> None:
    rng = random.Random(4)
    rows = ["sequence,tier,start,stop,label"]
    for number in range(40):  # a later in each sequence: leading holds in about half the cross pairs
        start = 250 * number + rng.randrange(0, 200)
        stop = start + rng.randrange(500, 2000)
        rows += [f"s{number},face,{start / 1000:.3f},{stop / 1000:.3f},a",
                 f"s{number},head,{stop / 1000:.3f},{(stop + rng.randrange(500, 1500)) / 1000:.3f},b",
                 f"s{number},torso,19.000,20.000,end"]
    path = tmp_path / "meets.csv"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    corpus = read_corpus([path])
    rules = mine(corpus, corpus_arrays(corpus), MiningOptions())
    kinds = {(rule.kind, rule.expr) for rule in rules}
    assert (MEETS, ir.Relation(MEETS, "a", "b")) in kinds  # type: ignore[arg-type]
    assert (LEADS, ir.Relation(LEADS, "a", "b")) in kinds  # type: ignore[arg-type]
    assert not any(kind == MEETS and expr == ir.Relation(MEETS, "b", "a") for kind, expr in kinds)  # type: ignore[arg-type]


def test_every_pair_of_ends_is_one_bound_away() -> None:
    """Each bound names two different endpoints (a bound of an end with itself says nothing)."""
    for meaning in RELATIONS.values():
        for bound in meaning.bounds:
            assert bound.lower != bound.upper


def test_every_relation_is_one_the_rolling_horizon_can_summarise() -> None:
    """mse/solve/cpsat/horizon.py keeps a signal's first and last committed occurrence only:
    enough for a conjunction of bounds (the extremes decide it) and for "no overlap" (a new
    occurrence can only overlap the last).  A relation of another shape needs more there."""
    for meaning in RELATIONS.values():
        assert is_conjunction(meaning) or is_disjointness(meaning)
