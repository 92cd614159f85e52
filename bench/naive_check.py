"""An independent checker of one timeline against one model, written from docs/semantics.md
alone ("Timelines", "Truth values", "Instantiation") without mse.ir.evaluate: the bench's second
opinion on what `mse check` accepts.  Plain loops over every assignment of occurrences; slow and
obvious on purpose.  Reads the IR model's data types only."""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence

from mse.ir import model as ir

Occ = tuple[int, int]  # start, stop in ms
UNKNOWN = None


def _term(term: ir.Term, chosen: Mapping[str, Occ], duration: int) -> int:
    if isinstance(term, ir.Constant):
        return term.value
    if isinstance(term, ir.DurationTime):
        return duration + term.offset
    start, stop = chosen[term.signal]
    return (start if term.edge == "start" else stop) + term.offset


def _holds(atom: ir.Relation | ir.Compare, chosen: Mapping[str, Occ], duration: int) -> bool:
    if isinstance(atom, ir.Relation):
        (a0, a1), (b0, b1) = chosen[atom.left], chosen[atom.right]
        return {
            "includes": a0 <= b0 and b1 <= a1,
            "excludes": a1 <= b0 or b1 <= a0,
            "precedes": a1 <= b0,
            "rightincludes": a0 <= b1 <= a1,
        }[atom.kind]
    x, y = _term(atom.left, chosen, duration), _term(atom.right, chosen, duration)
    return {"<": x < y, ">": x > y, "<=": x <= y, ">=": x >= y, "=": abs(x - y) <= atom.tolerance}[atom.op]


def _value(expr: ir.Expr, occurs: Mapping[str, Sequence[Occ]], duration: int) -> bool | None:
    if isinstance(expr, ir.Exists):
        return bool(occurs.get(expr.signal))
    if isinstance(expr, ir.Relation | ir.Compare):
        names = sorted(set(ir.atom_signals(expr)))
        if any(not occurs.get(n) for n in names):
            return UNKNOWN
        return all(_holds(expr, dict(zip(names, pick, strict=True)), duration)
                   for pick in itertools.product(*(occurs[n] for n in names)))
    if isinstance(expr, ir.Not):
        inner = _value(expr.operand, occurs, duration)
        return None if inner is None else not inner
    if isinstance(expr, ir.Implies):
        left = _value(expr.left, occurs, duration)
        return _value(ir.Or((ir.Not(expr.left), expr.right)), occurs, duration) if left is not None else (
            True if _value(expr.right, occurs, duration) is True else None)
    values = [_value(e, occurs, duration) for e in (expr.operands if isinstance(expr, ir.And | ir.Or) else ())]
    if isinstance(expr, ir.And):
        return False if False in values else (None if None in values else True)
    return True if True in values else (None if None in values else False)


def problems(model: ir.Model, occurrences: Sequence[tuple[str, int, int]], duration: int) -> list[str]:
    """What is wrong with the timeline (empty: consistent)."""
    found: list[str] = []
    by_signal: dict[str, list[Occ]] = {}
    signals = {s.id: s for s in model.signals}
    for name, start, stop in occurrences:
        if name not in signals:
            found.append(f"{name} is not a signal of {model.name}")
            continue
        by_signal.setdefault(name, []).append((start, stop))
        signal = signals[name]
        length = stop - start
        if not 0 <= start < stop <= duration:
            found.append(f"{name} [{start}, {stop}] outside [0, {duration}]")
        if length < round(signal.min_duration * 1000) or (
                signal.max_duration is not None and length > round(signal.max_duration * 1000)):
            found.append(f"{name} lasts {length} ms")
    for name, spans in by_signal.items():
        signal = signals[name]
        if signal.repetitivity == 0 and len(spans) > 1:
            found.append(f"{name} occurs {len(spans)} times")
        if signal.max_occurrences is not None and len(spans) > signal.max_occurrences:
            found.append(f"{name} occurs more than {signal.max_occurrences} times")
    exclusive = {m.name for m in model.modalities if m.exclusive}
    flat = [(name, start, stop) for name, spans in by_signal.items() for start, stop in spans]
    for (n1, s1, e1), (n2, s2, e2) in itertools.combinations(flat, 2):
        same_modality = signals[n1].modality == signals[n2].modality and signals[n1].modality in exclusive
        if (n1 == n2 or same_modality) and s1 < e2 and s2 < e1:
            found.append(f"{n1} and {n2} overlap")
    for constraint in model.constraints:
        triggers = ir.trigger_signals(constraint.expr)
        if triggers and not any(by_signal.get(t) for t in triggers):
            continue
        if _value(constraint.expr, by_signal, duration) is False:
            found.append(f"constraint {constraint.id} violated")
    return found
