"""Random behaviour sets for bench/speed/cpsat.py: feasible ones with a planted timeline, and
infeasible ones with a small planted conflict.

``feasible_set(signals, constraints, seed)`` first draws a *witness* timeline (some signals
present, exclusive modalities respected) and then keeps only constraints that the witness
satisfies, so every set it returns has a consistent timeline at ``duration``.  Styles cover
every operator (exists, includes, excludes, precedes, rightincludes, <, <=, >, >=, =,
equal with tolerance, and, or, not, implies), nesting, chains, exclusive modalities,
repetition and mandatory signals.  ``infeasible_set`` adds a chain of mandatory signals too
long for the timeline (the explanation is that chain and its duration rules).

The sets are returned as XML text, so that diagnostics carry file:line like a user's file.
"""

from __future__ import annotations

import random
import re
from collections.abc import Sequence

from mse.ir import model as ir
from mse.ir.evaluate import constraint_status
from mse.ir.printer import expr_text
from mse.ir.schedule import to_ticks

MODALITIES = ("face", "head", "gaze", "gesture", "torso")
EXCLUSIVE = ("face", "gaze", "gesture", "torso")
RELATIONS: tuple[ir.RelationKind, ...] = ("includes", "excludes", "precedes", "rightincludes")
STYLES = ("needs-relation", "needs", "relation", "relation", "chain", "offset", "equal", "exists",
          "nested", "compare")


def _signals(count: int, rng: random.Random) -> list[ir.Signal]:
    signals = []
    for index in range(count):
        low = rng.randint(3, 25) / 10
        high = None if rng.random() < 0.1 else round(low + rng.randint(0, 30) / 10, 1)
        start, end = rng.randint(0, 10) / 10, rng.randint(0, 10) / 10
        if start == end == 0 and rng.random() < 0.7:
            end = 0.5
        repetitive = rng.random() < 0.15
        signals.append(ir.Signal(
            id=f"s{index + 1:03d}", modality=rng.choice(MODALITIES), lexeme=f"lex=s{index + 1}",
            min_duration=low, max_duration=high, probability_start=start, probability_end=end,
            repetitivity=int(repetitive),
            max_occurrences=(rng.randint(2, 4) if repetitive and rng.random() < 0.5 else None)))
    return signals


def _witness(signals: Sequence[ir.Signal], duration: int, rng: random.Random) -> dict[str, list[tuple[int, int]]]:
    """A random consistent placement of some signals (exclusive modalities respected)."""
    busy: dict[str, list[tuple[int, int]]] = {m: [] for m in EXCLUSIVE}
    placed: dict[str, list[tuple[int, int]]] = {}
    for signal in rng.sample(list(signals), len(signals)):
        if rng.random() > 0.35 or signal.probability_start == signal.probability_end == 0:
            continue
        low = to_ticks(signal.min_duration)
        high = duration if signal.max_duration is None else min(duration, to_ticks(signal.max_duration))
        if low > high or low > duration:
            continue
        for _ in range(8):
            length = rng.randint(low, high)
            start = rng.randint(0, duration - length) // 100 * 100
            occurrence = (start, start + length)
            taken = busy.get(signal.modality)
            if taken is not None and any(a < occurrence[1] and occurrence[0] < b for a, b in taken):
                continue
            if taken is not None:
                taken.append(occurrence)
            placed[signal.id] = [occurrence]
            break
    return placed


def _expression(style: str, a: str, b: str, rng: random.Random, ids: Sequence[str], local: bool = False) -> ir.Expr:
    if style == "needs-relation":
        return ir.And((ir.Exists(a), ir.Relation(rng.choice(RELATIONS), a, b)))
    if style == "needs":
        return ir.Implies(ir.Exists(b), ir.Exists(a))
    if style == "relation":
        return ir.Relation(rng.choice(RELATIONS), a, b)
    if style == "chain":
        return ir.Compare("=", ir.SignalTime(b, "start"), ir.SignalTime(a, "stop", rng.choice([0, 200])),
                          tolerance=rng.choice([0, 300]))
    if style == "offset":
        if rng.random() < 0.5:
            return ir.Compare(">", ir.SignalTime(a, "start"), ir.Constant(rng.randint(0, 8) * 500))
        return ir.Compare("<=", ir.SignalTime(a, "stop"), ir.DurationTime(-rng.randint(0, 4) * 500))
    if style == "equal":
        return ir.Compare("=", ir.SignalTime(a, "start"), ir.SignalTime(b, "start"), tolerance=300)
    if style == "compare":
        op = rng.choice(("<", "<=", ">", ">="))
        return ir.Compare(op, ir.SignalTime(a, rng.choice(("start", "stop"))),
                          ir.SignalTime(b, rng.choice(("start", "stop")), rng.choice([0, 500, -500])))
    if style == "exists":
        return ir.Exists(a)
    # nested: two or three atoms under and/or/not/implies
    atoms: list[ir.Expr] = []
    for _ in range(rng.randint(2, 3)):
        x, y = (a, rng.choice([i for i in ids if i != a])) if rng.random() < 0.3 and not local else (a, b)
        atoms.append(_expression(rng.choice(("relation", "compare", "exists", "equal")), x, y, rng, ids, local))
    shape = rng.choice(("and", "or", "implies", "not-or"))
    if shape == "and":
        return ir.And(tuple(atoms))
    if shape == "or":
        return ir.Or(tuple(atoms))
    if shape == "implies":
        return ir.Implies(atoms[0], ir.Or(tuple(atoms[1:])) if len(atoms) > 2 else atoms[1])
    return ir.Not(ir.And(tuple(atoms)))


def _xml(name: str, signals: Sequence[ir.Signal], exprs: Sequence[ir.Expr], exclusive: Sequence[str]) -> str:
    lines = ['<?xml version="1.0" encoding="UTF-8"?>', f'<expression name="{name}">']
    lines += [f'  <modality name="{m}" exclusive="true"/>' for m in exclusive]
    lines.append("  <signals>")
    for s in signals:
        attributes = [f'id="{s.id}"', f'modality="{s.modality}"', f'lexeme="{s.lexeme}"',
                      f'min_duration="{s.min_duration:g}"']
        if s.max_duration is not None:
            attributes.append(f'max_duration="{s.max_duration:g}"')
        attributes += [f'probability_start="{s.probability_start:g}"',
                       f'probability_end="{s.probability_end:g}"']
        if s.repetitive:
            attributes.append('repetitivity="1"')
            if s.max_occurrences is not None:
                attributes.append(f'max_occurrences="{s.max_occurrences}"')
        lines.append(f"    <signal {' '.join(attributes)}/>")
    lines += ["  </signals>", "  <constraints>"]
    for index, expr in enumerate(exprs):
        text = expr_text(expr).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
        lines.append(f'    <constraint id="c{index + 1}">{text}</constraint>')
    lines += ["  </constraints>", "</expression>", ""]
    return "\n".join(lines)


def feasible_set(signals: int, constraints: int, seed: int, duration: float = 10.0, *,
                 locality: int | None = None, mandatory: float = 1.0) -> str:
    """XML of a set with ``signals`` signals and ``constraints`` constraints that has a
    consistent timeline of ``duration`` seconds (a planted witness satisfies every constraint).

    ``locality`` k relates signals only within groups of k consecutive ids (as an author
    relates the signals of one display, or as several displays merged into one file do),
    instead of any two signals; ``mandatory`` scales how often a constraint demands a signal
    (``exists``)."""
    rng = random.Random(seed)
    members = _signals(signals, rng)
    ids = [s.id for s in members]
    ticks = to_ticks(duration)
    witness = _witness(members, ticks, rng)
    present = sorted(witness)
    exprs: list[ir.Expr] = []
    attempts = 0
    while len(exprs) < constraints and attempts < 50 * constraints:
        attempts += 1
        style = rng.choice(STYLES)
        if style in ("needs-relation", "exists") and rng.random() > mandatory:
            continue
        if style in ("needs-relation", "exists") and present and rng.random() < 0.7:
            a = rng.choice(present)
        else:
            a = rng.choice(ids)
        if locality is None:
            b = rng.choice([i for i in ids if i != a])
        else:
            at = ids.index(a) // locality * locality
            b = rng.choice([i for i in ids[at:at + locality] if i != a] or [i for i in ids if i != a])
        expr = _expression(style, a, b, rng, ids, locality is not None)
        constraint = ir.Constraint(id="c", expr=expr)
        if constraint_status(constraint, witness, ticks) is not False:
            exprs.append(expr)
    return _xml(f"feasible_{signals}_{constraints}_{seed}", members, exprs, EXCLUSIVE)


def infeasible_set(signals: int, constraints: int, seed: int, duration: float = 10.0) -> str:
    """A feasible set plus a conflict, by ``seed % 3``: a chain of three mandatory signals,
    each starting when the previous stops, too long for the timeline; four of the set's own
    signals of one exclusive modality required and made too long to fit side by side; or a
    precedence cycle among three of the set's signals, all required."""
    text = feasible_set(signals, constraints, seed, duration)
    rng = random.Random(seed + 1)
    ids = [f"s{index + 1:03d}" for index in range(signals)]
    kind = seed % 3
    extra: list[str] = []
    modality = rng.choice(EXCLUSIVE)
    members = [m for m, where in re.findall(r'<signal id="(s\d+)" modality="(\w+)"', text) if where == modality]
    if kind == 1 and len(members) < 2:
        kind = 0
    if kind == 0:
        a, b, c = rng.sample(ids, 3)
        third = duration / 3 + 0.2
        extra = [f'    <signal id="k{i}" modality="head" lexeme="head=k{i}" min_duration="{third:g}"/>'
                 for i in (1, 2, 3)]
        conflict = [
            '    <constraint id="k_needs">exists(k1) and exists(k2) and exists(k3)</constraint>',
            '    <constraint id="k_chain">start(k2) = stop(k1) and start(k3) &gt;= stop(k2)</constraint>',
            f'    <constraint id="k_first">stop(k1) &lt;= start({a}) or not exists({b}) or exists({c})</constraint>',
        ]
    elif kind == 1:
        chosen = rng.sample(members, min(4, len(members)))
        longest = duration / len(chosen) + 0.3
        conflict = [f'    <constraint id="k_need">{" and ".join(f"exists({n})" for n in chosen)}</constraint>']
        conflict += [f'    <constraint id="k_long_{n}">stop({n}) &gt;= start({n}) + {longest:g}</constraint>'
                     for n in chosen]
    else:
        a, b, c = rng.sample(ids, 3)
        conflict = [
            f'    <constraint id="k_needs">exists({a}) and exists({b}) and exists({c})</constraint>',
            f'    <constraint id="k_ab">precedes({a}, {b})</constraint>',
            f'    <constraint id="k_bc">start({c}) &gt;= stop({b})</constraint>',
            f'    <constraint id="k_ca">precedes({c}, {a})</constraint>',
        ]
    if extra:
        text = text.replace("  </signals>", "\n".join(extra) + "\n  </signals>", 1)
    return text.replace("  </constraints>", "\n".join(conflict) + "\n  </constraints>", 1)
