"""Behaviour sets built from the shapes the walk finds hard (issue 32, item 3), for
``bench/speed/hard_shapes.py`` and ``tests/test_greedy_hard.py``.

Five shapes, each a small *gadget* of a few signals and constraints:

* ``ladder``: a precedes ladder ``exists(a1) and precedes(a1, a2)``, ``exists(a2) and
  precedes(a2, a3)``, ... with the last rung often mandatory: the whole chain must fit
  before the end of the timeline, so its first rung cannot start late;
* ``tolerance``: a chain of equalities with tolerance ``exists(a1) and equal(start(a2),
  stop(a1), 0.3)``, ... with a mandatory end, sometimes with a late or early bound;
* ``exclusion``: an exclusion cycle ``excludes(a1, a2)``, ``excludes(a2, a3)``, ...,
  ``excludes(ak, a1)`` between long signals, most of them mandatory, so they must be laid
  side by side; or ``exists(a1) implies not exists(a2)``, ... around a cycle with an
  ``or`` demanding one of them;
* ``implies``: an implies chain ``exists(a1) implies exists(a2)``, ... with ``precedes``
  between consecutive links and a bound on the last one: placing the first link late leaves
  no room for the rest;
* ``late``: mandatory signals with a late lower bound (``start(x) >= 6``) in one exclusive
  modality, with likely optional signals of the same modality that may take their room.

A set (:func:`hard_model`) is one shape (or ``mixed``: all five) repeated as gadgets, plus
filler signals with light random constraints (bench/generators/corpus.py's styles).  Every
set is *planted*: a witness timeline is drawn with the gadgets (exclusive modalities
respected) and a constraint is kept only when the witness satisfies it, so every set admits a
timeline; the bench still asks CP-SAT (its ground truth).  A set is drawn from its seed alone.
"""

from __future__ import annotations

import itertools
import random
from collections.abc import Callable

from bench.generators.corpus import random_constraints
from mse.ir import model as ir
from mse.ir.evaluate import is_violated
from mse.ir.printer import expr_text
from mse.ir.schedule import to_ticks

SHAPES = ("ladder", "tolerance", "exclusion", "implies", "late")
MODALITIES = ("face", "head", "gaze", "gesture", "torso")
EXCLUSIVE = ("face", "gaze", "gesture", "torso")
#: The modality a gadget moves to when its own exclusive modality has no room left.
OPEN = "head"
#: Share of a set's signals that belong to gadgets (the rest are fillers).
GADGET_SHARE = 0.6

Intervals = dict[str, list[tuple[int, int]]]


def _start(signal: str) -> ir.SignalTime:
    return ir.SignalTime(signal, "start")


def _stop(signal: str, offset: int = 0) -> ir.SignalTime:
    return ir.SignalTime(signal, "stop", offset)


class Board:
    """The witness timeline being drawn: occurrences and the busy time of exclusive modalities."""

    def __init__(self, duration: int, rng: random.Random) -> None:
        self.duration = duration
        self.rng = rng
        self.busy: dict[str, list[tuple[int, int]]] = {m: [] for m in EXCLUSIVE}
        self.placed: Intervals = {}

    def free(self, modality: str, start: int, stop: int) -> bool:
        return not any(a < stop and start < b for a, b in self.busy.get(modality, ()))

    def fits(self, modality: str, spans: list[tuple[int, int]]) -> bool:
        ok = all(0 <= a < b <= self.duration and self.free(modality, a, b) for a, b in spans)
        return ok and not any(a < d and c < b for i, (a, b) in enumerate(spans) for c, d in spans[i + 1:])

    def take(self, signal: str, modality: str, span: tuple[int, int]) -> None:
        self.placed[signal] = [span]
        if modality in self.busy:
            self.busy[modality].append(span)


class Gadget:
    """Signals and constraints of one gadget, and the witness occurrences it wants."""

    def __init__(self) -> None:
        self.signals: list[ir.Signal] = []
        self.exprs: list[ir.Expr] = []
        self.spans: dict[str, tuple[int, int]] = {}


def _signal(signal_id: str, modality: str, low: int, high: int | None, p_start: float, p_end: float) -> ir.Signal:
    return ir.Signal(id=signal_id, modality=modality, lexeme=f"lex={signal_id}", min_duration=low / 1000,
                     max_duration=None if high is None else high / 1000,
                     probability_start=p_start, probability_end=p_end)


def _probability(rng: random.Random) -> tuple[float, float]:
    return rng.randint(1, 10) / 10, rng.randint(0, 10) / 10


def _lengths(rng: random.Random, count: int, total: int) -> list[tuple[int, int]]:
    """``count`` (min, max) lengths in ms whose minimums add up to about ``total``."""
    found = []
    for _ in range(count):
        low = max(200, round(total / count * rng.uniform(0.6, 1.4) / 100) * 100)
        found.append((low, low + rng.randint(0, 10) * 100))
    return found


def _sequence(board: Board, modality: str, lengths: list[int], first: int, last: int,
              gaps: Callable[[], int]) -> list[tuple[int, int]] | None:
    """Spans of ``lengths`` one after the other (gaps drawn by ``gaps``) inside [first, last]."""
    rng = board.rng
    total = sum(lengths)
    for _ in range(12):
        spans, at = [], rng.randint(first, max(first, last - total))
        for length in lengths:
            at += gaps() if spans else 0
            spans.append((at, at + length))
            at += length
        if spans[-1][1] <= last and spans[0][0] >= 0 and board.fits(modality, spans):
            return spans
    return None


def ladder(ids: list[str], board: Board, modality: str) -> Gadget:
    rng, duration, gadget = board.rng, board.duration, Gadget()
    lengths = _lengths(rng, len(ids), round(duration * rng.uniform(0.35, 0.75)))
    for name, (low, high) in zip(ids, lengths, strict=True):
        gadget.signals.append(_signal(name, modality, low, high, *_probability(rng)))
    for first, second in itertools.pairwise(ids):
        gadget.exprs.append(ir.And((ir.Exists(first), ir.Relation("precedes", first, second))))
    if rng.random() < 0.6:
        gadget.exprs.append(ir.Exists(ids[-1]))
    if rng.random() < 0.4:
        gadget.exprs.append(ir.Compare("<=", _stop(ids[-1]), ir.DurationTime(-rng.randint(0, 4) * 500)))
    spans = _sequence(board, modality, [low for low, _ in lengths], 0, duration - 2000 * (rng.random() < 0.4),
                      lambda: rng.randint(0, 3) * 100)
    if spans is not None:
        gadget.spans = dict(zip(ids, spans, strict=True))
    return gadget


def tolerance(ids: list[str], board: Board, modality: str) -> Gadget:
    rng, duration, gadget = board.rng, board.duration, Gadget()
    lengths = _lengths(rng, len(ids), round(duration * rng.uniform(0.3, 0.6)))
    tol = rng.choice((200, 300, 500))
    for name, (low, high) in zip(ids, lengths, strict=True):
        gadget.signals.append(_signal(name, rng.choice(MODALITIES) if rng.random() < 0.5 else modality,
                                      low, high, *_probability(rng)))
    gap = rng.choice((0, 0, 200, 500))
    for first, second in itertools.pairwise(ids):
        gadget.exprs.append(ir.And((ir.Exists(first), ir.Compare("=", _start(second), _stop(first, gap), tol))))
    if rng.random() < 0.7:
        gadget.exprs.append(ir.Exists(ids[-1]))
    roll = rng.random()
    if roll < 0.3:
        gadget.exprs.append(ir.Compare(">=", _start(ids[0]), ir.Constant(rng.randint(1, 6) * 500)))
    elif roll < 0.6:
        gadget.exprs.append(ir.Compare("=", _start(ids[0]), _start(rng.choice(ids[1:])), tol)
                            if len(ids) > 2 and rng.random() < 0.3 else
                            ir.Compare("<=", _stop(ids[-1]), ir.DurationTime(-rng.randint(1, 4) * 500)))
    witness = [s.modality for s in gadget.signals]
    spans = None
    for _ in range(12):
        at = rng.randint(0, duration // 2)
        found = []
        for index, signal in enumerate(gadget.signals):
            length = to_ticks(signal.min_duration)
            if index:
                at = found[-1][1] + gap + rng.randint(-tol, tol) // 100 * 100
            found.append((at, at + length))
        if all(board.fits(m, [s]) for m, s in zip(witness, found, strict=True)) and found[-1][1] <= duration:
            spans = found
            break
    if spans is not None:
        gadget.spans = dict(zip(ids, spans, strict=True))
    return gadget


def exclusion(ids: list[str], board: Board, modality: str) -> Gadget:
    rng, duration, gadget = board.rng, board.duration, Gadget()
    if rng.random() < 0.7:
        # excludes around a cycle of long signals, most of them mandatory
        lengths = _lengths(rng, len(ids), round(duration * rng.uniform(0.4, 0.8)))
        for name, (low, high) in zip(ids, lengths, strict=True):
            gadget.signals.append(_signal(name, rng.choice(MODALITIES), low, high, *_probability(rng)))
        for index, name in enumerate(ids):
            gadget.exprs.append(ir.Relation("excludes", name, ids[(index + 1) % len(ids)]))
            if rng.random() < 0.7:
                gadget.exprs.append(ir.Exists(name))
        order = rng.sample(range(len(ids)), len(ids))
        lows = [lengths[i][0] for i in order]
        placed = None
        for _ in range(12):
            total = sum(lows)
            at, spans = rng.randint(0, max(0, duration - total)), []
            ok = True
            for index, length in zip(order, lows, strict=True):
                span = (at, at + length)
                if not board.fits(gadget.signals[index].modality, [span]):
                    ok = False
                    break
                spans.append((index, span))
                at += length + rng.randint(0, 2) * 100
            if ok and spans[-1][1][1] <= duration:
                placed = spans
                break
        if placed is not None:
            gadget.spans = {ids[index]: span for index, span in placed}
        return gadget
    # exists(a_i) implies not exists(a_i+1) around the cycle, one of them demanded
    lengths = _lengths(rng, len(ids), round(duration * 0.3))
    for name, (low, high) in zip(ids, lengths, strict=True):
        gadget.signals.append(_signal(name, modality, low, high, *_probability(rng)))
    for index, name in enumerate(ids):
        gadget.exprs.append(ir.Implies(ir.Exists(name), ir.Not(ir.Exists(ids[(index + 1) % len(ids)]))))
    gadget.exprs.append(ir.Or(tuple(ir.Exists(name) for name in ids)))
    chosen = rng.randrange(len(ids))
    low = lengths[chosen][0]
    for _ in range(12):
        at = rng.randint(0, duration - low)
        if board.fits(modality, [(at, at + low)]):
            gadget.spans = {ids[chosen]: (at, at + low)}
            break
    return gadget


def implies(ids: list[str], board: Board, modality: str) -> Gadget:
    rng, duration, gadget = board.rng, board.duration, Gadget()
    lengths = _lengths(rng, len(ids), round(duration * rng.uniform(0.3, 0.6)))
    for index, (name, (low, high)) in enumerate(zip(ids, lengths, strict=True)):
        p = (0.9, 0.9) if index == 0 else _probability(rng)
        gadget.signals.append(_signal(name, modality, low, high, *p))
    for first, second in itertools.pairwise(ids):
        gadget.exprs.append(ir.Implies(ir.Exists(first), ir.Exists(second)))
        gadget.exprs.append(ir.Relation("precedes", first, second) if rng.random() < 0.7 else
                            ir.Compare(">=", _start(second), _stop(first, rng.choice((0, 200, 500)))))
    gadget.exprs.append(ir.Compare("<=", _stop(ids[-1]), ir.DurationTime(-rng.randint(0, 6) * 500)))
    if rng.random() < 0.3:
        gadget.exprs.append(ir.Exists(ids[0]))
    spans = _sequence(board, modality, [low for low, _ in lengths], 0, duration - 3000,
                      lambda: rng.randint(5, 6) * 100)
    if spans is not None:
        gadget.spans = dict(zip(ids, spans, strict=True))
    return gadget


def late(ids: list[str], board: Board, modality: str) -> Gadget:
    rng, duration, gadget = board.rng, board.duration, Gadget()
    if modality not in EXCLUSIVE:
        modality = rng.choice(EXCLUSIVE)
    mandatory = ids[: max(1, len(ids) // 2)]
    optional = ids[len(mandatory):]
    bound = round(duration * rng.uniform(0.4, 0.8) / 500) * 500
    room = duration - bound
    lengths = _lengths(rng, len(mandatory), round(room * rng.uniform(0.4, 0.8)))
    for name, (low, high) in zip(mandatory, lengths, strict=True):
        gadget.signals.append(_signal(name, modality, low, high, *_probability(rng)))
        gadget.exprs.append(ir.Exists(name))
        gadget.exprs.append(ir.Compare(">=", _start(name), ir.Constant(bound))
                            if rng.random() < 0.6 else
                            ir.Compare(">=", _start(name), ir.DurationTime(bound - duration)))
    for name in optional:
        low = rng.randint(10, 30) * 100
        gadget.signals.append(_signal(name, modality, low, None if rng.random() < 0.5 else low + 3000,
                                      rng.randint(6, 10) / 10, rng.randint(6, 10) / 10))
    spans = _sequence(board, modality, [low for low, _ in lengths], bound, duration,
                      lambda: rng.randint(0, 2) * 100)
    if spans is not None:
        gadget.spans = dict(zip(mandatory, spans, strict=True))
    return gadget


GADGETS: dict[str, Callable[[list[str], Board, str], Gadget]] = {
    "ladder": ladder, "tolerance": tolerance, "exclusion": exclusion, "implies": implies, "late": late,
}


def hard_model(seed: int, signals: int, shape: str = "mixed", duration: float = 10.0) -> ir.Model:
    """A behaviour set of about ``signals`` signals built from ``shape`` gadgets ("mixed": all
    five shapes) and fillers, that admits a timeline of ``duration`` seconds (a planted
    witness satisfies every constraint)."""
    rng = random.Random(seed)
    ticks = to_ticks(duration)
    board = Board(ticks, rng)
    members: list[ir.Signal] = []
    exprs: list[ir.Expr] = []
    counter = 0

    def new_ids(count: int) -> list[str]:
        nonlocal counter
        found = [f"s{counter + i + 1:03d}" for i in range(count)]
        counter += count
        return found

    budget = max(3, round(signals * GADGET_SHARE))
    while counter < budget:
        kind = rng.choice(SHAPES) if shape == "mixed" else shape
        size = rng.randint(2, 4) if kind == "late" else rng.randint(3, 6)
        ids = new_ids(min(size, max(2, budget - counter)) if budget - counter >= 2 else 2)
        gadget = GADGETS[kind](ids, board, rng.choice(MODALITIES))
        if not gadget.spans and kind != "late":
            gadget = GADGETS[kind](ids, board, OPEN)  # no room in that modality: the open one
        for signal in gadget.signals:
            span = gadget.spans.get(signal.id)
            if span is not None and board.free(signal.modality, *span):
                board.take(signal.id, signal.modality, span)
        members.extend(gadget.signals)
        exprs.extend(gadget.exprs)
    # fillers: ordinary signals, present in the witness with probability 0.5, light constraints
    fillers = new_ids(max(0, signals - counter))
    for name in fillers:
        low = rng.randint(3, 20) * 100
        high = None if rng.random() < 0.15 else low + rng.randint(0, 20) * 100
        signal = _signal(name, rng.choice(MODALITIES), low, high, *_probability(rng))
        members.append(signal)
        if rng.random() < 0.5:
            for _ in range(8):
                at = rng.randint(0, ticks - low)
                if board.free(signal.modality, at, at + low):
                    board.take(name, signal.modality, (at, at + low))
                    break
    if len(fillers) > 1:
        exprs.extend(random_constraints(rng, fillers, len(fillers) // 2))
    kept = [expr for expr in exprs if not is_violated(ir.Constraint(id="c", expr=expr), board.placed, ticks)]
    return ir.Model(
        name=f"hard_{shape}_{signals}_{seed}",
        signals=tuple(members),
        constraints=tuple(
            ir.Constraint(id=f"c{i + 1}", expr=expr, explicit_id=False, text=expr_text(expr))
            for i, expr in enumerate(kept)
        ),
        modalities=tuple(ir.Modality(m, True) for m in EXCLUSIVE),
    )


#: Signals per set in the bench's corpus, and the shapes; :func:`corpus` crosses them.
SIZES = (12, 25, 50, 100, 200, 400)


def corpus(count: int, seed: int = 32) -> list[tuple[int, int, str, float]]:
    """``count`` (model seed, signals, shape, duration) drawn from ``seed``: every shape and
    ``mixed`` in turn, sizes drawn (more small sets than large ones), ``max(10, size / 10)``
    seconds or twice that."""
    rng = random.Random(seed)
    shapes = (*SHAPES, "mixed")
    weights = (6, 5, 4, 3, 2, 1)
    found = []
    for index in range(count):
        size = rng.choices(SIZES, weights)[0]
        # about one gadget signal per 150 ms at most: larger sets are longer displays
        duration = rng.choice((1.0, 1.0, 2.0)) * max(10, size // 10)
        found.append((seed * 100_000 + index, size, shapes[index % len(shapes)], duration))
    return found
