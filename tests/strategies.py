"""Hypothesis strategies for random behaviour sets, shared by the solver tests.

Stable API (other test modules import these names):

* ``models(min_signals=1, max_signals=6, max_constraints=6, repetitive=True,
  exclusive=True, styles=ALL_STYLES)`` -> valid :class:`mse.ir.model.Model`
* ``signals(ids, modalities=...)`` -> tuple of :class:`mse.ir.model.Signal`
* ``constraint_exprs(ids, styles=ALL_STYLES)`` -> one :class:`mse.ir.model.Expr`

Generated sets look like the paper's: durations of 0.1-4 s, probabilities on a 0.1 grid,
constraints in the styles the bundled and Greta sets use (``exists(a) and includes(a, b)``,
``exists(b) implies exists(a)``, ``start(b) = stop(a) + 0.2``, ``start(x) > 2``,
``equal(start(a), start(b), 0.3)``, ``length(a) >= 1.5``, excludes/precedes, ...), plus arbitrary nested
connectives (style ``"nested"``).  A generated set is well formed but need not admit a
consistent timeline: solvers may answer "no solution" for some of them.
"""

from __future__ import annotations

from collections.abc import Sequence

from hypothesis import strategies as st

from mse.ir import model as ir
from mse.ir import relations
from mse.ir.printer import expr_text

MODALITIES = ("face", "head", "gaze", "gesture", "torso")
#: every relation and comparison of the one table (mse.ir.relations)
RELATIONS: tuple[ir.RelationKind, ...] = tuple(relations.RELATIONS)  # type: ignore[arg-type]
COMPARE_OPS: tuple[ir.CompareOp, ...] = tuple(relations.COMPARISONS)  # type: ignore[arg-type]

#: Constraint styles (pass a subset as ``styles=`` to restrict generation).
ALL_STYLES = (
    "needs-relation",  # exists(a) and R(a, b)
    "needs",  # exists(b) implies exists(a)
    "relation",  # R(a, b)
    "chain",  # start(b) = stop(a) + offset
    "offset",  # start(x) > 2 / stop(x) <= duration - 1
    "equal",  # equal(start(a), start(b), tol)
    "length",  # length(a) >= 1.5 / 2 > length(a) / equal(length(a), 1, tol)
    "exists",  # exists(a)
    "nested",  # random connectives over random atoms
)


def _ms(low: int, high: int) -> st.SearchStrategy[int]:
    return st.integers(low, high)


def _probability() -> st.SearchStrategy[float]:
    return st.integers(0, 10).map(lambda tenth: tenth / 10)


@st.composite
def _signal(draw: st.DrawFn, signal_id: str, modalities: Sequence[str], repetitive: bool) -> ir.Signal:
    minimum = draw(_ms(100, 3000))
    extra = draw(st.one_of(st.none(), _ms(0, 3000)))
    maximum = None if extra is None else (minimum + extra) / 1000
    start = draw(_probability())
    end = draw(_probability())
    if start == 0 and end == 0:
        end = 0.5  # an inactive signal is a lint warning, not an interesting test case
    return ir.Signal(
        id=signal_id,
        modality=draw(st.sampled_from(list(modalities))),
        lexeme=f"lex={signal_id}",
        min_duration=minimum / 1000,
        max_duration=maximum,
        probability_start=start,
        probability_end=end,
        repetitivity=draw(st.sampled_from([0, 1])) if repetitive else 0,
    )


def signals(
    ids: Sequence[str], modalities: Sequence[str] = MODALITIES, repetitive: bool = True
) -> st.SearchStrategy[tuple[ir.Signal, ...]]:
    return st.tuples(*(_signal(i, modalities, repetitive) for i in ids))


def _signal_time(ids: Sequence[str]) -> st.SearchStrategy[ir.SignalTime]:
    return st.builds(
        ir.SignalTime,
        signal=st.sampled_from(list(ids)),
        edge=st.sampled_from(["start", "stop"]),
        offset=st.sampled_from([0, 0, 200, -200, 500, 1000]),
    )


def _term(ids: Sequence[str]) -> st.SearchStrategy[ir.Term]:
    return st.one_of(
        _signal_time(ids),
        st.builds(ir.Constant, value=st.integers(0, 8).map(lambda s: s * 500)),
        st.builds(ir.DurationTime, offset=st.sampled_from([0, -1000, -2000])),
    )


def _atom(ids: Sequence[str]) -> st.SearchStrategy[ir.Expr]:
    names = st.sampled_from(list(ids))
    compare = st.builds(
        ir.Compare,
        op=st.sampled_from(list(COMPARE_OPS)),
        left=_signal_time(ids),
        right=_term(ids),
        tolerance=st.sampled_from([0, 0, 300]),
    ).map(lambda c: c if c.op == "=" else ir.Compare(c.op, c.left, c.right))
    return st.one_of(
        st.builds(ir.Exists, names),
        st.builds(ir.Relation, st.sampled_from(list(RELATIONS)), names, names),
        compare,
        names.flatmap(_length),
    )


@st.composite
def _length(draw: st.DrawFn, signal: str) -> ir.Compare:
    """``length(a) op k`` or ``k op length(a)`` as the parser builds them (docs/semantics.md)."""
    op = draw(st.sampled_from(list(COMPARE_OPS)))
    k = draw(st.integers(0, 8)) * 250
    tolerance = draw(st.sampled_from([0, 300])) if op == "=" else 0
    if draw(st.booleans()):
        return ir.Compare(op, ir.SignalTime(signal, "stop"), ir.SignalTime(signal, "start", k), tolerance)
    return ir.Compare(op, ir.SignalTime(signal, "start", k), ir.SignalTime(signal, "stop"), tolerance)


def _flat(kind: type[ir.And] | type[ir.Or], operands: tuple[ir.Expr, ...]) -> tuple[ir.Expr, ...]:
    """Operands of nested ``and``/``or`` of the same kind spliced in, as the parser builds them."""
    return tuple(part for op in operands for part in (op.operands if isinstance(op, kind) else (op,)))


def _nested(ids: Sequence[str]) -> st.SearchStrategy[ir.Expr]:
    def extend(inner: st.SearchStrategy[ir.Expr]) -> st.SearchStrategy[ir.Expr]:
        pair = st.lists(inner, min_size=2, max_size=3).map(tuple)
        return st.one_of(
            st.builds(ir.Not, inner),
            pair.map(lambda operands: ir.And(_flat(ir.And, operands))),
            pair.map(lambda operands: ir.Or(_flat(ir.Or, operands))),
            st.builds(ir.Implies, inner, inner),
        )

    return st.recursive(_atom(ids), extend, max_leaves=4)


@st.composite
def _two(draw: st.DrawFn, ids: Sequence[str]) -> tuple[str, str]:
    first = draw(st.sampled_from(list(ids)))
    others = [i for i in ids if i != first] or [first]
    return first, draw(st.sampled_from(others))


@st.composite
def constraint_exprs(draw: st.DrawFn, ids: Sequence[str], styles: Sequence[str] = ALL_STYLES) -> ir.Expr:
    """One constraint expression over ``ids`` in one of ``styles``."""
    style = draw(st.sampled_from(list(styles)))
    a, b = draw(_two(ids))
    if style == "needs-relation":
        kind = draw(st.sampled_from(list(RELATIONS)))
        return ir.And((ir.Exists(a), ir.Relation(kind, a, b)))
    if style == "needs":
        return ir.Implies(ir.Exists(b), ir.Exists(a))
    if style == "relation":
        return ir.Relation(draw(st.sampled_from(list(RELATIONS))), a, b)
    if style == "chain":
        offset = draw(st.sampled_from([0, 0, 200, 500]))
        return ir.Compare("=", ir.SignalTime(b, "start"), ir.SignalTime(a, "stop", offset))
    if style == "offset":
        if draw(st.booleans()):
            seconds = draw(st.integers(0, 4)) * 500
            return ir.Compare(">", ir.SignalTime(a, "start"), ir.Constant(seconds))
        return ir.Compare("<=", ir.SignalTime(a, "stop"), ir.DurationTime(-draw(st.integers(0, 2)) * 500))
    if style == "equal":
        return ir.Compare("=", ir.SignalTime(a, "start"), ir.SignalTime(b, "start"), tolerance=300)
    if style == "exists":
        return ir.Exists(a)
    if style == "length":
        return draw(_length(a))
    return draw(_nested(ids))


@st.composite
def models(
    draw: st.DrawFn,
    min_signals: int = 1,
    max_signals: int = 6,
    max_constraints: int = 6,
    repetitive: bool = True,
    exclusive: bool = True,
    styles: Sequence[str] = ALL_STYLES,
) -> ir.Model:
    """A valid model: unique ids ``s1..sN``, resolved constraints with canonical text."""
    count = draw(st.integers(min_signals, max_signals))
    ids = [f"s{i + 1}" for i in range(count)]
    members = draw(signals(ids, repetitive=repetitive))
    exprs = draw(st.lists(constraint_exprs(ids, styles), max_size=max_constraints))
    constraints = tuple(
        ir.Constraint(id=f"c{i + 1}", expr=expr, explicit_id=False, text=expr_text(expr))
        for i, expr in enumerate(exprs)
    )
    used = sorted({s.modality for s in members})
    exclusive_names = draw(st.sets(st.sampled_from(used))) if exclusive and used else set()
    modalities = tuple(ir.Modality(name, True) for name in sorted(exclusive_names))
    return ir.Model(name="generated", signals=members, constraints=constraints, modalities=modalities)
