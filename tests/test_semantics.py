"""Truth tables of every operator (with unknowns) and the trigger rule: docs/semantics.md."""

from __future__ import annotations

import itertools

import pytest

from mse.api import loads
from mse.ir import model as ir
from mse.ir.evaluate import check_schedule, constraint_status, evaluate_expr
from mse.ir.schedule import Occurrence, Schedule

PRESENT = {"p": [(0, 1000)]}
TRUE = ir.Exists("p")
FALSE = ir.Exists("absent")
UNKNOWN = ir.Relation("includes", "p", "absent")
VALUES = {True: TRUE, False: FALSE, None: UNKNOWN}


def value(expr: ir.Expr) -> bool | None:
    return evaluate_expr(expr, PRESENT, 10_000)


def test_atoms_used_for_tables() -> None:
    assert (value(TRUE), value(FALSE), value(UNKNOWN)) == (True, False, None)


@pytest.mark.parametrize("a", [True, False, None])
def test_not(a: bool | None) -> None:
    assert value(ir.Not(VALUES[a])) == (None if a is None else not a)


KLEENE_AND = {
    (True, True): True, (True, False): False, (True, None): None,
    (False, True): False, (False, False): False, (False, None): False,
    (None, True): None, (None, False): False, (None, None): None,
}  # fmt: skip
KLEENE_OR = {
    (True, True): True, (True, False): True, (True, None): True,
    (False, True): True, (False, False): False, (False, None): None,
    (None, True): True, (None, False): None, (None, None): None,
}  # fmt: skip
KLEENE_IMPLIES = {
    (True, True): True, (True, False): False, (True, None): None,
    (False, True): True, (False, False): True, (False, None): True,
    (None, True): True, (None, False): None, (None, None): None,
}  # fmt: skip


@pytest.mark.parametrize("a,b", list(itertools.product([True, False, None], repeat=2)))
def test_binary_connectives(a: bool | None, b: bool | None) -> None:
    assert value(ir.And((VALUES[a], VALUES[b]))) == KLEENE_AND[(a, b)]
    assert value(ir.Or((VALUES[a], VALUES[b]))) == KLEENE_OR[(a, b)]
    assert value(ir.Implies(VALUES[a], VALUES[b])) == KLEENE_IMPLIES[(a, b)]


# (a interval, b interval) -> expected truth of each relation(a, b)
RELATION_CASES = [
    ((0, 10), (2, 5), {"includes": True, "excludes": False, "precedes": False, "rightincludes": True}),
    ((0, 10), (0, 10), {"includes": True, "excludes": False, "precedes": False, "rightincludes": True}),
    ((2, 5), (0, 10), {"includes": False, "excludes": False, "precedes": False, "rightincludes": False}),
    ((0, 5), (5, 8), {"includes": False, "excludes": True, "precedes": True, "rightincludes": False}),
    ((0, 5), (-3, 5), {"includes": False, "excludes": False, "precedes": False, "rightincludes": True}),
    ((0, 5), (6, 8), {"includes": False, "excludes": True, "precedes": True, "rightincludes": False}),
    ((6, 8), (0, 5), {"includes": False, "excludes": True, "precedes": False, "rightincludes": False}),
    ((3, 8), (0, 5), {"includes": False, "excludes": False, "precedes": False, "rightincludes": True}),
    ((3, 8), (0, 3), {"includes": False, "excludes": True, "precedes": False, "rightincludes": True}),
    ((0, 5), (3, 8), {"includes": False, "excludes": False, "precedes": False, "rightincludes": False}),
]


@pytest.mark.parametrize("a,b,expected", RELATION_CASES)
def test_relations(a: tuple[int, int], b: tuple[int, int], expected: dict[str, bool]) -> None:
    intervals = {"a": [a], "b": [b]}
    for kind, truth in expected.items():
        relation = ir.Relation(kind, "a", "b")  # type: ignore[arg-type]
        assert evaluate_expr(relation, intervals, 100) is truth, (kind, a, b)
        assert evaluate_expr(relation, {"a": [a]}, 100) is None
        assert evaluate_expr(relation, {"b": [b]}, 100) is None


def test_relation_holds_for_every_combination_of_occurrences() -> None:
    inside_both = {"a": [(0, 10), (20, 30)], "b": [(2, 5)]}
    relation = ir.Relation("precedes", "b", "a")
    assert evaluate_expr(relation, inside_both, 100) is False  # b precedes (20,30) but not (0,10)
    assert evaluate_expr(relation, {"a": [(6, 10), (20, 30)], "b": [(2, 5)]}, 100) is True


def s(signal: str, edge: str = "start", offset: int = 0) -> ir.SignalTime:
    return ir.SignalTime(signal, edge, offset)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "expr,expected",
    [
        (ir.Compare("<", s("a"), s("b")), True),
        (ir.Compare(">", s("a"), s("b")), False),
        (ir.Compare("<=", s("a", "stop"), s("b")), True),  # 1000 <= 1000
        (ir.Compare("<", s("a", "stop"), s("b")), False),
        (ir.Compare(">=", s("b"), s("a", "stop")), True),
        (ir.Compare("=", s("b"), s("a", "stop")), True),
        (ir.Compare("=", s("b"), s("a", "stop", 300)), False),
        (ir.Compare("=", s("b"), s("a", "stop", 300), 300), True),
        (ir.Compare("=", s("b"), s("a", "stop", 301), 300), False),
        (ir.Compare("<=", s("b", "stop"), ir.DurationTime()), True),
        (ir.Compare("<=", s("b", "stop"), ir.DurationTime(-1000)), True),
        (ir.Compare("<=", s("b", "stop"), ir.DurationTime(-1001)), False),
        (ir.Compare(">", s("b"), ir.Constant(999)), True),
        (ir.Compare(">", s("b"), ir.Constant(1000)), False),
        (ir.Compare("<", s("a"), s("missing")), None),
        (ir.Compare("<", s("missing"), ir.Constant(5)), None),
    ],
)
def test_comparisons(expr: ir.Expr, expected: bool | None) -> None:
    intervals = {"a": [(0, 1000)], "b": [(1000, 3000)]}
    assert evaluate_expr(expr, intervals, 4000) is expected


def test_same_signal_on_both_sides_uses_one_occurrence() -> None:
    length_at_least_1s = ir.Compare(">=", s("a", "stop"), s("a", "start", 1000))
    assert evaluate_expr(length_at_least_1s, {"a": [(0, 1000), (2000, 3500)]}, 5000) is True


WORKED = """<expression name="worked"><signals>
<signal id="a" modality="face"/><signal id="b" modality="head"/></signals>
<constraints><constraint id="c">exists(a) and includes(a, b)</constraint></constraints></expression>"""


@pytest.mark.parametrize(
    "intervals,status,violated",
    [
        ({}, None, False),  # neither occurs: ignored
        ({"a": [(0, 5000)]}, None, False),  # only a: includes is unknown, and is unknown: fine
        ({"b": [(0, 5000)]}, False, True),  # only b: b needs a
        ({"a": [(0, 5000)], "b": [(1000, 2000)]}, True, False),  # both, b within a
        ({"a": [(0, 5000)], "b": [(1000, 6000)]}, False, True),  # both, b sticks out
    ],
)
def test_worked_example_of_the_trigger_rule(
    intervals: dict[str, list[tuple[int, int]]], status: bool | None, violated: bool
) -> None:
    model = loads(WORKED)
    constraint = model.constraints[0]
    assert constraint.triggers == {"a", "b"}
    assert constraint_status(constraint, intervals, 10_000) is status
    schedule = Schedule.of(10_000, [Occurrence(x, y, sig) for sig, spans in intervals.items() for x, y in spans])
    assert bool(check_schedule(model, schedule)) is violated


def test_exists_only_constraints_are_always_evaluated() -> None:
    model = loads(
        """<expression name="x"><signals><signal id="frown" modality="face"/><signal id="a" modality="face"/>
        <signal id="b" modality="head"/></signals><constraints><constraint id="must">exists(frown)</constraint>
        <constraint id="needs">exists(b) implies exists(a)</constraint></constraints></expression>"""
    )
    must, needs = model.constraints
    assert must.triggers == frozenset() and needs.triggers == frozenset()
    assert constraint_status(must, {}, 1000) is False
    assert constraint_status(needs, {"b": [(0, 10)]}, 1000) is False
    assert constraint_status(needs, {"b": [(0, 10)], "a": [(0, 10)]}, 1000) is True
    assert constraint_status(needs, {}, 1000) is True


STRUCTURE = """<expression name="s"><modality name="gaze" exclusive="true"/><signals>
<signal id="g1" modality="gaze" min_duration="1" max_duration="2"/>
<signal id="g2" modality="gaze" min_duration="1" max_duration="2" repetitivity="1" max_occurrences="2"/>
<signal id="f" modality="face"/></signals></expression>"""


@pytest.mark.parametrize(
    "occurrences,kinds",
    [
        ([("g1", 0, 1500), ("g2", 1500, 2500), ("g2", 3000, 4000)], []),
        ([("g1", 0, 500)], ["duration"]),
        ([("g1", 0, 2500)], ["duration"]),
        ([("g1", 9500, 11000)], ["bounds"]),
        ([("g1", 0, 1000), ("g1", 2000, 3000)], ["repetition"]),
        ([("g2", 0, 1500), ("g2", 1000, 2200)], ["overlap"]),
        ([("g1", 0, 1500), ("g2", 1000, 2000)], ["exclusive"]),
        ([("g2", 0, 1000), ("g2", 1000, 2000), ("g2", 2000, 3000)], ["repetition"]),
        ([("nope", 0, 1000)], ["unknown-signal"]),
    ],
)
def test_structural_rules(occurrences: list[tuple[str, int, int]], kinds: list[str]) -> None:
    model = loads(STRUCTURE)
    schedule = Schedule.of(10_000, [Occurrence(a, b, sig) for sig, a, b in occurrences])
    assert sorted(v.kind for v in check_schedule(model, schedule)) == sorted(kinds)
