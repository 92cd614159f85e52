"""The one table of what each relation and each comparison means (docs/semantics.md).

Every relational atom is a few *bounds* ``x - y <= k`` on the integer-millisecond grid,
joined by ``and`` or ``or``: a relation's bounds are between endpoints (the start or stop
of its left or right interval), a comparison's between its left and right term.  ``k`` is
0 (``x <= y``), -1 (``x < y``, strict) or the atom's tolerance.  What makes an atom false
is derived, never written: the negation of each bound (``x - y > k``) joined by the dual
connective.

Everything that gives these atoms a meaning reads this table: the evaluator and its fast
checker (:mod:`mse.ir.evaluate`), the greedy sampler's truth-value masks and generated
checks, its edges and start bounds, the CP-SAT encoding and the miner.  Adding a relation
or a comparison is one entry here (plus its spelling in the grammar); tests/test_relations.py
registers a relation that exists only in the tests and checks it through every consumer.

Hot paths compile a meaning to Python source once (:meth:`Meaning.source`) instead of
interpreting the table per check.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any, Generic, Literal, TypeVar

from mse.diagnostics import Diagnostic, MseError
from mse.ir import model as ir

#: The slack of a strict bound: ``x < y`` is ``x - y <= -1`` on the 1 ms grid.
STRICT = -1
#: The slack of ``x <= y``.
LOOSE = 0
#: The slack standing for the atom's own tolerance (``equal(x, y, tol)``).
TOLERANCE = None

Joined = Literal["and", "or"]
Side = Literal["left", "right"]
_End = TypeVar("_End")
_Made = TypeVar("_Made")


@dataclass(frozen=True, slots=True)
class Endpoint:
    """The start or the stop of a relation's left or right interval."""

    side: Side
    edge: ir.Edge

    def __str__(self) -> str:
        return f"{'a' if self.side == 'left' else 'b'}.{self.edge}"


@dataclass(frozen=True, slots=True)
class Bound(Generic[_End]):
    """``lower - upper <= slack``: ``lower <= upper`` (slack 0), ``lower < upper`` (-1), or
    ``lower - upper <= tolerance`` with the atom's own tolerance (slack None)."""

    lower: _End
    upper: _End
    slack: int | None = LOOSE

    def limit(self, tolerance: int) -> int:
        return tolerance if self.slack is None else self.slack


@dataclass(frozen=True, slots=True)
class Meaning(Generic[_End]):
    """Bounds joined by ``and`` or ``or``: when the atom is true."""

    bounds: tuple[Bound[_End], ...]
    joined: Joined = "and"

    def holds(self, value: Callable[[_End], int], tolerance: int = 0) -> bool:
        """The truth of the atom given the value of each endpoint (or term)."""
        results = (value(b.lower) - value(b.upper) <= b.limit(tolerance) for b in self.bounds)
        return all(results) if self.joined == "and" else any(results)

    def source(
        self,
        lower: Callable[[_End], str],
        upper: Callable[[_End], str],
        *,
        negated: bool = False,
        tolerance: str = "tolerance",
    ) -> str:
        """Python source of the condition (or, ``negated``, of its negation: each bound
        reversed and the dual connective), each bound written on ``lower(x)`` and
        ``upper(y)``.  With ranges of possible values, ``lower`` giving the smallest and
        ``upper`` the largest says whether the atom *may* be true; the negation with the
        largest and the smallest whether it may be false."""
        parts = []
        for bound in self.bounds:
            x, y = lower(bound.lower), upper(bound.upper)
            if bound.slack is None:
                parts.append(f"{x} - {y} {'>' if negated else '<='} {tolerance}")
            elif bound.slack == STRICT:
                parts.append(f"{x} {'>=' if negated else '<'} {y}")
            elif bound.slack == LOOSE:
                parts.append(f"{x} {'>' if negated else '<='} {y}")
            else:
                parts.append(f"{x} - {y} {'>' if negated else '<='} {bound.slack}")
        conjunction = (self.joined == "and") != negated
        return f" {'and' if conjunction else 'or'} ".join(parts)

    def text(self, name: Callable[[_End], str] = str) -> str:
        """As docs/semantics.md writes it: "`a.start ≤ b.start` and `b.stop ≤ a.stop`"."""

        def one(bound: Bound[_End]) -> str:
            x, y = name(bound.lower), name(bound.upper)
            if bound.slack is None:
                return f"`{x} − {y} ≤ tol`"
            if bound.slack in (LOOSE, STRICT):
                return f"`{x} {'<' if bound.slack == STRICT else '≤'} {y}`"
            return f"`{x} − {y} ≤ {bound.slack} ms`"

        return f" {self.joined} ".join(one(b) for b in self.bounds)


RelationMeaning = Meaning[Endpoint]
CompareMeaning = Meaning[Side]

_A_START, _A_STOP = Endpoint("left", "start"), Endpoint("left", "stop")
_B_START, _B_STOP = Endpoint("right", "start"), Endpoint("right", "stop")

#: What ``kind(a, b)`` means for one interval ``a`` of its left signal and one ``b`` of its
#: right.  The order of the bounds is the order in which consumers build their parts (the
#: CP-SAT encoding creates literals in it), so it is kept.
RELATIONS: dict[str, RelationMeaning] = {
    "precedes": Meaning((Bound(_A_STOP, _B_START),)),
    "includes": Meaning((Bound(_A_START, _B_START), Bound(_B_STOP, _A_STOP))),
    "rightincludes": Meaning((Bound(_A_START, _B_STOP), Bound(_B_STOP, _A_STOP))),
    "excludes": Meaning((Bound(_A_STOP, _B_START), Bound(_B_STOP, _A_START)), "or"),
}

#: What ``left op right`` means, as bounds between the two terms.
COMPARISONS: dict[str, CompareMeaning] = {
    "<": Meaning((Bound("left", "right", STRICT),)),
    "<=": Meaning((Bound("left", "right"),)),
    ">": Meaning((Bound("right", "left", STRICT),)),
    ">=": Meaning((Bound("right", "left"),)),
    "=": Meaning((Bound("left", "right", TOLERANCE), Bound("right", "left", TOLERANCE))),
}


# -- derived facts ------------------------------------------------------------------------
def swapped(endpoint: Endpoint) -> Endpoint:
    return Endpoint("right" if endpoint.side == "left" else "left", endpoint.edge)


def is_symmetric(meaning: RelationMeaning) -> bool:
    """``kind(a, b)`` says the same as ``kind(b, a)``."""
    bounds = {(b.lower, b.upper, b.slack) for b in meaning.bounds}
    return bounds == {(swapped(b.lower), swapped(b.upper), b.slack) for b in meaning.bounds}


def is_disjointness(meaning: RelationMeaning) -> bool:
    """The meaning is "the two intervals do not overlap" (``a.stop <= b.start or b.stop <=
    a.start``), whose fold over many occurrences is a sweep instead of every pair."""
    return meaning.joined == "or" and set(meaning.bounds) == {Bound(_A_STOP, _B_START), Bound(_B_STOP, _A_START)}


def is_conjunction(meaning: Meaning[_End]) -> bool:
    """True for every combination of occurrences iff the extreme values satisfy each bound
    (a single bound is a conjunction of one)."""
    return meaning.joined == "and" or len(meaning.bounds) == 1


#: Index of an edge in an interval ``(start, stop)``; a possible-times box
#: ``(start_lo, start_hi, stop_lo, stop_hi)`` holds edge ``i`` at ``2 i`` and ``2 i + 1``.
EDGE_INDEX: Mapping[str, int] = {"start": 0, "stop": 1}


def known_time(term: ir.Term, duration: int) -> int:
    """The value of a term that names no signal: a time known before solving (the
    timeline's duration, a constant).  The one place a new kind of such term is added."""
    if isinstance(term, ir.DurationTime):
        return duration + term.offset
    if isinstance(term, ir.Constant):
        return term.value
    if isinstance(term, ir.SpeechTime):
        raise unresolved_anchor(term)
    raise TypeError(f"{term!r} names a signal: its time is an occurrence's")


def unresolved_anchor(term: ir.SpeechTime) -> MseError:
    """E219 for a speech anchor reaching a solver or the evaluator: its time is the request's
    speech, which :func:`mse.ir.anchors.resolve_anchors` puts in first."""
    from mse.ir.printer import term_text

    return MseError([Diagnostic(
        "E219",
        f"{term_text(term)} refers to the agent's speech, but no speech was given "
        "(mse sample/check --speech FILE, a timeline's 'utterances', or mse.ir.anchors.resolve_anchors)",
        term.span,
    )])


class PerEntry(dict[str, _Made]):
    """Something made from each entry of a table (a compiled check, a fold), on first use:
    an entry added to the table later, as tests/test_relations.py does, is made too."""

    def __init__(self, make: Callable[[str], _Made]) -> None:
        super().__init__()
        self._make = make

    def __missing__(self, key: str) -> _Made:
        made = self[key] = self._make(key)
        return made


def compiled(parameters: str, body: str) -> Callable[..., Any]:
    """``lambda parameters: body`` made once, for hot paths: a meaning's :meth:`Meaning.source`
    runs as plain comparisons instead of interpreting the table per call.  ``body`` is
    only ever built from this table (indices, operators, parameter names)."""
    function: Callable[..., Any] = eval(f"lambda {parameters}: {body}", {"__builtins__": {}})
    return function


def endpoint_of(names: tuple[str, str], indices: Mapping[str, int]) -> Callable[[Endpoint], str]:
    """Source of an endpoint as ``name[index]``: ``names`` of the left and right interval,
    ``indices`` of each edge in it."""
    return lambda end: f"{names[0] if end.side == 'left' else names[1]}[{indices[end.edge]}]"


@functools.cache
def interval_test(kind: str) -> Callable[[tuple[int, int], tuple[int, int]], bool]:
    """``kind(a, b)`` for one interval ``(start, stop)`` of each signal, compiled once."""
    edge = endpoint_of(("a", "b"), EDGE_INDEX)
    return compiled("a, b", RELATIONS[kind].source(edge, edge))


@functools.cache
def compare_test(op: str) -> Callable[[int, int, int], bool]:
    """``left op right`` within ``tolerance``, compiled once."""
    return compiled("left, right, tolerance", COMPARISONS[op].source(str, str))


def describe() -> Iterator[str]:
    """One line per relation, as the table of docs/semantics.md lists it (checked by
    tests/test_relations.py)."""
    for kind, meaning in RELATIONS.items():
        yield f"| `{kind}(a, b)` | {meaning.text()} |"
