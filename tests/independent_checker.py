"""A second checker of timelines, written straight from docs/semantics.md without reading
``mse.ir.evaluate``: the repair tests and bench/evaluation/repair.py accept a timeline only when both
this and the project's evaluator find it consistent.

It reads the typed model (``mse.ir.model``: data, no semantics) and a list of occurrences
``(signal, start, stop)`` in milliseconds.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

from mse.ir import model as ir

Occ = tuple[str, int, int]
UNKNOWN = None


def _ms(seconds: float) -> int:
    return round(seconds * 1000)


def occurrence_problems(model: ir.Model, occurrences: Sequence[Occ], duration: int) -> list[str]:
    """The rules of "Timelines" in docs/semantics.md."""
    found = []
    signals = {s.id: s for s in model.signals}
    by_signal: dict[str, list[tuple[int, int]]] = {}
    for name, start, stop in occurrences:
        if name not in signals:
            found.append(f"{name} is not a signal")
            continue
        signal = signals[name]
        if not 0 <= start < stop <= duration:
            found.append(f"{name} [{start}, {stop}] outside [0, {duration}]")
        length = stop - start
        if length < _ms(signal.min_duration) or (signal.max_duration is not None
                                                   and length > _ms(signal.max_duration)):
            found.append(f"{name} lasts {length} ms")
        by_signal.setdefault(name, []).append((start, stop))
    for name, spans in by_signal.items():
        signal = signals[name]
        most = 1 if signal.repetitivity == 0 else signal.max_occurrences
        if most is not None and len(spans) > most:
            found.append(f"{name} occurs {len(spans)} times")
        for (a0, a1), (b0, b1) in itertools.combinations(spans, 2):
            if a0 < b1 and b0 < a1:
                found.append(f"{name} overlaps itself")
    exclusive = {m.name for m in model.modalities if m.exclusive}
    for first, second in itertools.combinations(occurrences, 2):
        if first[0] == second[0] or first[0] not in signals or second[0] not in signals:
            continue
        modality = signals[first[0]].modality
        same = modality in exclusive and modality == signals[second[0]].modality
        if same and first[1] < second[2] and second[1] < first[2]:
            found.append(f"{first[0]} and {second[0]} overlap in {modality}")
    return found


def _time(term: ir.Term, chosen: dict[str, tuple[int, int]], duration: int) -> int:
    if isinstance(term, ir.Constant):
        return term.value
    if isinstance(term, ir.DurationTime):
        return duration + term.offset
    start, stop = chosen[term.signal]
    return (start if term.edge == "start" else stop) + term.offset


def _relation_holds(atom: ir.Relation | ir.Compare, chosen: dict[str, tuple[int, int]], duration: int) -> bool:
    if isinstance(atom, ir.Relation):
        (a0, a1), (b0, b1) = chosen[atom.left], chosen[atom.right]
        if atom.kind == "includes":
            return a0 <= b0 and b1 <= a1
        if atom.kind == "excludes":
            return a1 <= b0 or b1 <= a0
        if atom.kind == "precedes":
            return a1 <= b0
        return a0 <= b1 <= a1  # rightincludes
    x, y = _time(atom.left, chosen, duration), _time(atom.right, chosen, duration)
    return {"<": x < y, ">": x > y, "<=": x <= y, ">=": x >= y, "=": abs(x - y) <= atom.tolerance}[atom.op]


def _value(expr: ir.Expr, spans: dict[str, list[tuple[int, int]]], duration: int) -> bool | None:
    if isinstance(expr, ir.Exists):
        return bool(spans.get(expr.signal))
    if isinstance(expr, ir.Relation | ir.Compare):
        names = list(dict.fromkeys(ir.atom_signals(expr)))
        if any(not spans.get(n) for n in names):
            return UNKNOWN
        return all(_relation_holds(expr, dict(zip(names, combo, strict=True)), duration)
                   for combo in itertools.product(*(spans[n] for n in names)))
    if isinstance(expr, ir.Not):
        inner = _value(expr.operand, spans, duration)
        return None if inner is None else not inner
    if isinstance(expr, ir.And):
        values = [_value(e, spans, duration) for e in expr.operands]
        return False if False in values else (None if None in values else True)
    if isinstance(expr, ir.Or):
        values = [_value(e, spans, duration) for e in expr.operands]
        return True if True in values else (None if None in values else False)
    assert isinstance(expr, ir.Implies)
    left, right = _value(expr.left, spans, duration), _value(expr.right, spans, duration)
    negated = None if left is None else not left
    values = [negated, right]
    return True if True in values else (None if None in values else False)


def constraint_problems(model: ir.Model, occurrences: Sequence[Occ], duration: int) -> list[str]:
    """The constraints violated ("Instantiation: when a constraint counts")."""
    spans: dict[str, list[tuple[int, int]]] = {}
    for name, start, stop in occurrences:
        spans.setdefault(name, []).append((start, stop))
    found = []
    for constraint in model.constraints:
        triggers = {name for node in ir.walk(constraint.expr) if isinstance(node, ir.Relation | ir.Compare)
                    for name in ir.atom_signals(node)}
        if triggers and not any(spans.get(t) for t in triggers):
            continue  # ignored: no trigger signal occurs
        if _value(constraint.expr, spans, duration) is False:
            found.append(constraint.id)
    return found


def problems(model: ir.Model, occurrences: Sequence[Occ], duration: int) -> list[str]:
    return occurrence_problems(model, occurrences, duration) + constraint_problems(model, occurrences, duration)
