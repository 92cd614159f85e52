"""``length(a)`` and ``stop(a) - start(b)`` in constraints (issue 18 item 3, docs/semantics.md)."""

from __future__ import annotations

import pytest

from mse.api import loads
from mse.diagnostics import MseError
from mse.ir import model as ir
from mse.ir.evaluate import constraint_status, evaluate_expr, is_consistent
from mse.ir.printer import expr_text
from mse.solve.protocol import SolveRequest, get_solver


def _doc(*constraints: str) -> str:
    body = "".join(f"<constraint id='c{i}'><![CDATA[{text}]]></constraint>" for i, text in enumerate(constraints))
    return (
        "<expression name='len'><signals>"
        "<signal id='a' modality='face' lexeme='smile' min_duration='0.5' max_duration='4'/>"
        "<signal id='b' modality='head' lexeme='nod' min_duration='0.5' max_duration='4'/>"
        f"</signals><constraints>{body}</constraints></expression>"
    )


def _expr(text: str) -> ir.Expr:
    return loads(_doc(text)).constraints[0].expr


@pytest.mark.parametrize(
    "text,expected",
    [
        ("length(a) >= 1", ir.Compare(">=", ir.SignalTime("a", "stop"), ir.SignalTime("a", "start", 1000))),
        ("stop(a) - start(a) >= 1", ir.Compare(">=", ir.SignalTime("a", "stop"), ir.SignalTime("a", "start", 1000))),
        ("2 > length(a)", ir.Compare(">", ir.SignalTime("a", "start", 2000), ir.SignalTime("a", "stop"))),
        ("length(a) - 1 <= 0.5", ir.Compare("<=", ir.SignalTime("a", "stop"), ir.SignalTime("a", "start", 1500))),
        ("stop(b) - start(a) < 0", ir.Compare("<", ir.SignalTime("b", "stop"), ir.SignalTime("a", "start"))),
        (
            "equal(length(a), 2, 0.1)",
            ir.Compare("=", ir.SignalTime("a", "stop"), ir.SignalTime("a", "start", 2000), 100),
        ),
        ("lessthan(length(b), 1)", ir.Compare("<", ir.SignalTime("b", "stop"), ir.SignalTime("b", "start", 1000))),
    ],
)
def test_length_is_a_comparison_of_two_times(text: str, expected: ir.Expr) -> None:
    assert _expr(text) == expected


@pytest.mark.parametrize(
    "text", ["length(a) >= 1", "2 > length(a)", "length(a) >= -0.5", "equal(length(a), 2, 0.1)", "length(b) = 1.25"]
)
def test_length_prints_as_written_and_reparses(text: str) -> None:
    expr = _expr(text)
    assert expr_text(expr) == text
    assert _expr(expr_text(expr)) == expr


@pytest.mark.parametrize(
    "intervals,expected",
    [
        ({}, None),  # a does not occur: unknown, like start/stop
        ({"b": [(0, 500)]}, None),
        ({"a": [(0, 1000)]}, True),
        ({"a": [(0, 999)]}, False),
        ({"a": [(0, 1000), (2000, 3500)]}, True),  # every occurrence at least 1 s
        ({"a": [(0, 1000), (2000, 2500)]}, False),  # one occurrence too short
    ],
)
def test_truth_table_of_length(intervals: dict[str, list[tuple[int, int]]], expected: bool | None) -> None:
    assert evaluate_expr(_expr("length(a) >= 1"), intervals, 10_000) is expected


def test_length_triggers_like_start_and_stop() -> None:
    model = loads(_doc("length(a) >= 1"))
    [constraint] = model.constraints
    assert constraint.triggers == frozenset({"a"})
    assert constraint_status(constraint, {"b": [(0, 500)]}, 5000) is None  # ignored


@pytest.mark.parametrize(
    "text", ["length(a) < length(b)", "length(a) <= duration - 1", "stop(a) - start(a) > start(b)"]
)
def test_length_against_anything_but_a_number_is_refused(text: str) -> None:
    with pytest.raises(MseError) as caught:
        loads(_doc(text))
    assert "E216" in str(caught.value)


def test_a_keyword_out_of_place_is_never_suggested_as_itself() -> None:
    with pytest.raises(MseError) as caught:
        loads(_doc("start(a) + start(b) > 2"))
    message = str(caught.value)
    assert "E110" in message and "did you mean 'start'" not in message


def test_misspelt_keyword_still_gets_a_suggestion() -> None:
    with pytest.raises(MseError) as caught:
        loads(_doc("lenght(a) > 2"))
    assert "did you mean 'length'" in str(caught.value)


@pytest.mark.parametrize("solver", ["greedy", "cpsat", "csp"])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_every_backend_honours_length(solver: str, seed: int) -> None:
    constraints = ("exists(a)", "length(a) >= 2", "exists(b)", "equal(length(b), 1, 0.1)", "stop(a) - start(b) >= 0")
    model = loads(_doc(*constraints))
    [schedule] = get_solver(solver).solve(model, SolveRequest(duration=8.0, seed=seed, time_limit=10.0)).schedules
    assert is_consistent(model, schedule)
    lengths = {o.signal: o.stop - o.start for o in schedule.occurrences}
    assert lengths["a"] >= 2000 and 900 <= lengths["b"] <= 1100
