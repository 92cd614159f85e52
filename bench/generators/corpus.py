"""Random behaviour sets for the sampler bench (``bench/speed/sample.py --corpus``).

Our own generator, independent of the test strategies: every operator (exists, includes,
excludes, precedes, rightincludes, <, >, <=, >=, = with and without tolerance, and, or, not,
implies), nesting, chains of ``start(b) = stop(a) + c``, exclusive modalities, repetitive
signals (with and without ``max_occurrences``), mandatory signals (``exists``), requirements
such as ``exists(a) and precedes(a, b)``, and wide constraints naming up to eight signals.
A set is drawn from a seed alone (``random.Random``), so a corpus is reproduced by its seeds.
Whether a set admits a timeline is for CP-SAT to say (the bench's ground truth).
"""

from __future__ import annotations

import itertools
import random

from mse.ir import model as ir
from mse.ir.printer import expr_text

MODALITIES = ("face", "head", "gaze", "gesture", "torso")
RELATIONS: tuple[ir.RelationKind, ...] = ("includes", "excludes", "precedes", "rightincludes")
OPS: tuple[ir.CompareOp, ...] = ("<", ">", "<=", ">=", "=")

#: Constraint styles and their weights.
STYLES = {
    "needs-relation": 4,  # exists(a) and R(a, b)
    "needs-order": 2,  # exists(a) and start(b) >= stop(a) + c
    "needs": 3,  # exists(b) implies exists(a)
    "relation": 5,  # R(a, b)
    "chain": 2,  # start(b) = stop(a) + c, for a chain a1 -> a2 -> a3
    "offset": 2,  # start(x) > 2 / stop(x) <= duration - 1
    "equal": 2,  # equal(start(a), start(b), 0.3)
    "exists": 2,  # exists(a)
    "exclusion": 1,  # exists(a) implies not exists(b)
    "nested": 4,  # random connectives over random atoms
    "wide": 1,  # R(x1, y) and exists(x1) or ... over up to 8 signals
}


def _seconds(rng: random.Random, low: int, high: int) -> float:
    """A multiple of 0.1 s in [low, high] tenths."""
    return rng.randint(low, high) / 10


def random_signal(rng: random.Random, signal_id: str) -> ir.Signal:
    minimum = _seconds(rng, 1, 30)
    maximum = None if rng.random() < 0.2 else round(minimum + _seconds(rng, 0, 30), 1)
    start, end = rng.randint(0, 10) / 10, rng.randint(0, 10) / 10
    if start == end == 0 and rng.random() < 0.7:
        end = 0.5  # a few signals that never occur by themselves, not many
    repetitive = rng.random() < 0.25
    most = rng.randint(1, 4) if repetitive and rng.random() < 0.3 else None
    return ir.Signal(
        id=signal_id, modality=rng.choice(MODALITIES), lexeme=f"lex={signal_id}",
        min_duration=minimum, max_duration=maximum, probability_start=start, probability_end=end,
        repetitivity=1 if repetitive else 0, max_occurrences=most,
    )


def _time(rng: random.Random, ids: list[str]) -> ir.SignalTime:
    return ir.SignalTime(rng.choice(ids), rng.choice(("start", "stop")), rng.choice((0, 0, 200, -200, 500, 1000)))


def _term(rng: random.Random, ids: list[str]) -> ir.Term:
    roll = rng.random()
    if roll < 0.7:
        return _time(rng, ids)
    if roll < 0.85:
        return ir.Constant(rng.randint(0, 16) * 500)
    return ir.DurationTime(-rng.randint(0, 4) * 500)


def _atom(rng: random.Random, ids: list[str]) -> ir.Expr:
    roll = rng.random()
    if roll < 0.25:
        return ir.Exists(rng.choice(ids))
    if roll < 0.65:
        a, b = _two(rng, ids)
        return ir.Relation(rng.choice(RELATIONS), a, b)
    op = rng.choice(OPS)
    tolerance = rng.choice((0, 300, 500)) if op == "=" else 0
    return ir.Compare(op, _time(rng, ids), _term(rng, ids), tolerance)


def _nested(rng: random.Random, ids: list[str], depth: int) -> ir.Expr:
    if depth <= 0 or rng.random() < 0.3:
        return _atom(rng, ids)
    roll = rng.random()
    if roll < 0.2:
        return ir.Not(_nested(rng, ids, depth - 1))
    if roll < 0.45:
        return ir.Implies(_nested(rng, ids, depth - 1), _nested(rng, ids, depth - 1))
    parts = tuple(_nested(rng, ids, depth - 1) for _ in range(rng.randint(2, 3)))
    kind = ir.And if roll < 0.75 else ir.Or
    flat = tuple(p for part in parts for p in (part.operands if isinstance(part, kind) else (part,)))
    return kind(flat)


def _two(rng: random.Random, ids: list[str]) -> tuple[str, str]:
    a = rng.choice(ids)
    others = [i for i in ids if i != a] or [a]
    return a, rng.choice(others)


def random_constraints(rng: random.Random, ids: list[str], count: int) -> list[ir.Expr]:
    styles, weights = zip(*STYLES.items(), strict=True)
    found: list[ir.Expr] = []
    while len(found) < count:
        style = rng.choices(styles, weights)[0]
        a, b = _two(rng, ids)
        if style == "needs-relation":
            found.append(ir.And((ir.Exists(a), ir.Relation(rng.choice(RELATIONS), a, b))))
        elif style == "needs-order":
            order = ir.Compare(">=", ir.SignalTime(b, "start"), ir.SignalTime(a, "stop", rng.choice((0, 200, 500))))
            found.append(ir.And((ir.Exists(a), order)))
        elif style == "needs":
            found.append(ir.Implies(ir.Exists(b), ir.Exists(a)))
        elif style == "relation":
            found.append(ir.Relation(rng.choice(RELATIONS), a, b))
        elif style == "chain":
            chain = rng.sample(ids, min(len(ids), rng.randint(2, 4)))
            for first, second in itertools.pairwise(chain):
                gap = ir.SignalTime(first, "stop", rng.choice((0, 0, 200, 500)))
                found.append(ir.Compare("=", ir.SignalTime(second, "start"), gap, rng.choice((0, 300))))
        elif style == "offset":
            if rng.random() < 0.5:
                found.append(ir.Compare(">", ir.SignalTime(a, "start"), ir.Constant(rng.randint(0, 8) * 500)))
            else:
                found.append(ir.Compare("<=", ir.SignalTime(a, "stop"), ir.DurationTime(-rng.randint(0, 4) * 500)))
        elif style == "equal":
            found.append(ir.Compare("=", ir.SignalTime(a, "start"), ir.SignalTime(b, "start"), 300))
        elif style == "exists":
            found.append(ir.Exists(a))
        elif style == "exclusion":
            found.append(ir.Implies(ir.Exists(a), ir.Not(ir.Exists(b))))
        elif style == "nested":
            found.append(_nested(rng, ids, rng.randint(1, 3)))
        else:  # wide
            target = a
            others = rng.sample([i for i in ids if i != target] or [target], min(len(ids) - 1 or 1, rng.randint(3, 7)))
            kind = rng.choice(RELATIONS)
            found.append(ir.Or(tuple(ir.And((ir.Relation(kind, x, target), ir.Exists(x))) for x in others)))
    return found[:count]


def random_model(seed: int, signals: int, constraints: int, name: str | None = None) -> ir.Model:
    """A behaviour set of ``signals`` signals and ``constraints`` constraints drawn from ``seed``."""
    rng = random.Random(seed)
    ids = [f"s{i + 1}" for i in range(signals)]
    members = tuple(random_signal(rng, i) for i in ids)
    exprs = random_constraints(rng, ids, constraints)
    used = sorted({s.modality for s in members})
    exclusive = [m for m in used if rng.random() < 0.4]
    return ir.Model(
        name=name or f"corpus{seed}",
        signals=members,
        constraints=tuple(
            ir.Constraint(id=f"c{i + 1}", expr=expr, explicit_id=False, text=expr_text(expr))
            for i, expr in enumerate(exprs)
        ),
        modalities=tuple(ir.Modality(m, True) for m in exclusive),
    )


def planted_model(seed: int, signals: int, constraints: int, duration: float, name: str | None = None) -> ir.Model:
    """A behaviour set that surely admits a timeline of ``duration`` seconds: a random
    timeline is drawn first (each signal present with probability 0.6, exclusive modalities
    respected), then random constraints (same styles as :func:`random_model`) are kept only
    when that timeline satisfies them."""
    from mse.ir.evaluate import is_violated
    from mse.ir.schedule import to_ticks

    rng = random.Random(seed)
    ids = [f"s{i + 1}" for i in range(signals)]
    members = tuple(random_signal(rng, i) for i in ids)
    used = sorted({s.modality for s in members})
    exclusive = {m for m in used if rng.random() < 0.4}
    ticks = to_ticks(duration)
    busy: dict[str, list[tuple[int, int]]] = {}
    intervals: dict[str, list[tuple[int, int]]] = {}
    for signal in members:
        if rng.random() > 0.6:
            continue
        low = to_ticks(signal.min_duration)
        high = ticks if signal.max_duration is None else min(ticks, to_ticks(signal.max_duration))
        if low > high:
            continue
        length = rng.randint(low, high)
        start = rng.randint(0, ticks - length)
        taken = busy.setdefault(signal.modality, []) if signal.modality in exclusive else []
        if any(start < stop and first < start + length for first, stop in taken):
            continue
        taken.append((start, start + length))
        intervals[signal.id] = [(start, start + length)]
    kept: list[ir.Expr] = []
    for _ in range(constraints * 50):
        for expr in random_constraints(rng, ids, 1):
            constraint = ir.Constraint(id="c", expr=expr)
            if not is_violated(constraint, intervals, ticks):
                kept.append(expr)
        if len(kept) >= constraints:
            break
    return ir.Model(
        name=name or f"planted{seed}",
        signals=members,
        constraints=tuple(
            ir.Constraint(id=f"c{i + 1}", expr=expr, explicit_id=False, text=expr_text(expr))
            for i, expr in enumerate(kept[:constraints])
        ),
        modalities=tuple(ir.Modality(m, True) for m in sorted(exclusive)),
    )
