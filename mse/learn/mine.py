"""Constraints mined from a corpus, each with its evidence (docs/learn.md, "Constraints").

A candidate rule is *tested* in a sequence when the evaluator would not ignore it and
would not find it unknown there (for ``precedes(a, b)``: both occur; for "b needs a":
b occurs).  Its **support** is the number of sequences where it is tested, its
**confidence** the fraction of those where it holds.  A rule is kept when

* support >= ``min_support`` and confidence >= ``confidence``, and
* it is **significant**: its *baseline* -- how often it holds when the signals' occurrences
  are taken from *different* sequences (cross pairs), i.e. how often it would hold by chance
  if the two signals were independent -- makes the observed count unlikely: the binomial
  tail ``P(X >= holds)`` for ``X ~ B(support, baseline)`` is at most ``significance``.
  A comparison whose offset was fitted to the data (``start(b) <= start(a) + 9.6``) holds
  about as often across sequences, so it is dropped; ``start(gaze) >= stop(mouth) - 0.5``,
  where the gaze waits for the mouth, is not.

Every relation of the table (mse.ir.relations) is mined.  Relations hold for every
combination of occurrences (docs/semantics.md), which for a conjunction of bounds (and for
the comparisons mined here) depends only on the first/last start and stop of each signal; a
disjunction (``excludes``) between repeated signals is checked pair by pair.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from itertools import combinations

import numpy as np

from mse.extras import require
from mse.ir import model as ir
from mse.ir.relations import RELATIONS, STRICT, Bound, Endpoint, interval_test, is_conjunction, is_symmetric
from mse.ir.schedule import to_ticks
from mse.learn.corpus import Corpus
from mse.learn.signals import ceil_to, floor_to
from mse.learn.stats import Bools, CorpusArrays, Floats, Ints, SignalArrays

#: An ``equal(x, y, tol)`` is written for two bounds around 0 when tol is at most this (s).
EQUAL_MAX_TOLERANCE = 0.5
#: Cross pairs per rule used to estimate a baseline: shifts of one signal's sequences.
BASELINE_SHIFTS = 7
#: Extreme observations whose mean spacing estimates how far a true limit lies beyond them.
SPACING_COUNT = 5

#: Order in which redundant rules are looked for (first = dropped first when implied); a
#: relation not listed ranks with ``precedes``.
RANK = {"needs": 0, "either": 1, "apart": 2, "excludes": 3, "bound": 4, "equal": 5, "rightincludes": 6,
        "includes": 7, "precedes": 8, "exists": 9}
#: How a mined relation's rule is named (``{left}_{kind}_{right}`` when not listed).
RULE_NAMES = {"precedes": "{left}_before_{right}", "excludes": "{left}_apart_from_{right}"}


@dataclass(frozen=True)
class BoundInfo:
    """Where a learned offset came from: ``y(b) - x(a)`` was at least (``side`` "lower") or at
    most ("upper") ``observed`` ms in the corpus; ``spacing`` is the mean gap between the most
    extreme observations (how far the true limit may lie beyond the sample), and the
    written offset is the observed one widened by it and rounded outward."""

    a: str
    x_edge: str
    b: str
    y_edge: str
    side: str
    observed: float
    spacing: float
    spread: float
    offset: float  # written, ms


@dataclass(frozen=True)
class Rule:
    """A mined constraint with its evidence."""

    id: str
    kind: str
    expr: ir.Expr
    support: int
    holds: int
    baseline: float | None  # None: no chance model (exists)
    p_value: float
    note: str = ""
    bound: BoundInfo | None = None

    @property
    def confidence(self) -> float:
        return self.holds / self.support if self.support else 0.0

    @property
    def rank(self) -> int:
        return RANK.get(self.kind, RANK["precedes"])

    def evidence(self) -> str:
        text = (f"support {self.support}, confidence {self.confidence:.3f} "
                f"(holds in {self.holds} of {self.support} sequences)")
        if self.baseline is not None:
            text += f"; by chance {self.baseline:.2f}, p = {self.p_value:.1e}"
        return text + (f"; {self.note}" if self.note else "")


@dataclass(frozen=True)
class MiningOptions:
    confidence: float = 0.95
    min_support: int = 10
    significance: float = 0.001


Rows = tuple[Floats, Floats, Floats, Floats]  # start_min, start_max, stop_min, stop_max
Holds = Callable[[Rows, Rows], Bools]


def _rows(data: SignalArrays, index: Ints) -> Rows:
    return data.start_min[index], data.start_max[index], data.stop_min[index], data.stop_max[index]


def _edge(rows: Rows, edge: str, extreme: str) -> Floats:
    return rows[(0 if edge == "start" else 2) + (0 if extreme == "min" else 1)]


def _tail(holds: int, support: int, baseline: float) -> float:
    """P(X >= holds) for X ~ Binomial(support, baseline)."""
    if holds <= 0:
        return 1.0
    if baseline >= 1.0:
        return 1.0
    if baseline <= 0.0:
        return 0.0
    if holds == support:  # the usual case at confidence 1: no need for scipy
        return float(baseline**support)
    with require("learn"):
        from scipy.stats import binom

    return float(binom.sf(holds - 1, support, baseline))


class Miner:
    def __init__(self, corpus: Corpus, arrays: CorpusArrays, options: MiningOptions) -> None:
        self.corpus = corpus
        self.arrays = arrays
        self.options = options
        self.rules: list[Rule] = []
        self.ids: set[str] = set()
        self.n = arrays.size

    def run(self) -> list[Rule]:
        signals = list(self.corpus.signals)
        for signal in signals:
            self._exists(signal)
        for a, b in combinations(signals, 2):
            self._presence(a, b)
            self._presence(b, a)
            self._apart(a, b)
            self._either(a, b)
            self._temporal(a, b)
        return self.rules

    # -- bookkeeping ----------------------------------------------------------------------
    def _id(self, text: str) -> str:
        candidate, number = text, 2
        while candidate in self.ids:
            candidate, number = f"{text}_{number}", number + 1
        self.ids.add(candidate)
        return candidate

    def _accept(self, kind: str, name: str, expr: ir.Expr, tested: Bools, holds: Bools,
                baseline: float | None, note: str = "", bound: BoundInfo | None = None) -> bool:
        support = int(tested.sum())
        hits = int((holds & tested).sum())
        options = self.options
        if support < options.min_support or hits < options.confidence * support - 1e-9:
            return False
        p_value = 0.0 if baseline is None else _tail(hits, support, baseline)
        if p_value > options.significance:
            return False
        self.rules.append(Rule(self._id(name), kind, expr, support, hits, baseline, p_value, note, bound))
        return True

    # -- presence rules ---------------------------------------------------------------------
    def _exists(self, signal: str) -> None:
        present = self.arrays.signals[signal].present
        everywhere = np.ones(self.n, dtype=bool)
        self._accept("exists", f"{signal}_occurs", ir.Exists(signal), everywhere, present, None)

    def _presence(self, needer: str, needed: str) -> None:
        """``exists(needer) implies exists(needed)``: needer needs needed."""
        tested = self.arrays.signals[needer].present
        other = self.arrays.signals[needed].present
        rate = float(other.mean())
        if rate >= 1.0 or not tested.any():
            return
        expr = ir.Implies(ir.Exists(needer), ir.Exists(needed))
        self._accept("needs", f"{needer}_needs_{needed}", expr, tested, other, rate)

    def _apart(self, a: str, b: str) -> None:
        """``exists(a) implies not exists(b)``: never together."""
        first, second = self.arrays.signals[a].present, self.arrays.signals[b].present
        # The sequences with the rarer signal are the trials, the other's absence the success.
        tested, other = (first, second) if first.sum() <= second.sum() else (second, first)
        rate = float((~other).mean())
        if rate >= 1.0:
            return
        expr = ir.Implies(ir.Exists(a), ir.Not(ir.Exists(b)))
        together = int((first & second).sum())
        expected = float(first.mean() * second.mean() * self.n)
        self._accept("apart", f"{a}_without_{b}", expr, tested, ~other, rate,
                     f"together in {together} sequences, {expected:.1f} expected if independent")

    def _either(self, a: str, b: str) -> None:
        """``exists(a) or exists(b)``: at least one of them."""
        first, second = self.arrays.signals[a].present, self.arrays.signals[b].present
        rate = 1.0 - float((~first).mean()) * float((~second).mean())
        if rate >= 1.0:
            return
        everywhere = np.ones(self.n, dtype=bool)
        neither = int((~first & ~second).sum())
        expected = float((~first).mean() * (~second).mean() * self.n)
        self._accept("either", f"{a}_or_{b}", ir.Or((ir.Exists(a), ir.Exists(b))), everywhere, first | second,
                     rate, f"neither in {neither} sequences, {expected:.1f} expected if independent")

    # -- temporal rules ---------------------------------------------------------------------
    def _temporal(self, a: str, b: str) -> None:
        sa, sb = self.arrays.signals[a], self.arrays.signals[b]
        both = np.flatnonzero(sa.present & sb.present)
        if len(both) < self.options.min_support:
            return
        ra, rb = _rows(sa, both), _rows(sb, both)
        cross = self._cross_pairs(sa, sb)
        ca, cb = (_rows(sa, cross[0]), _rows(sb, cross[1])) if cross is not None else (None, None)
        tested = np.ones(len(both), dtype=bool)

        def consider(kind: str, name: str, expr: ir.Expr, holds: Holds, note: str = "",
                     exact: Bools | None = None, bound: BoundInfo | None = None) -> bool:
            observed = holds(ra, rb) if exact is None else exact
            if observed.sum() < self.options.confidence * len(both) - 1e-9:
                return False
            baseline = float(holds(ca, cb).mean()) if ca is not None and cb is not None else 1.0
            return self._accept(kind, name, expr, tested, observed, baseline, note, bound)

        def relation(kind: str, left: str, right: str) -> None:
            name = RULE_NAMES.get(kind, "{left}_{kind}_{right}").format(left=left, kind=kind, right=right)
            holds = _flip(_relation_holds(kind), left != a)
            exact = None if is_conjunction(RELATIONS[kind]) else self._exact(kind, left, right, both)
            consider(kind, name, ir.Relation(kind, left, right), holds, exact=exact)  # type: ignore[arg-type]

        for left, right in ((a, b), (b, a)):  # each order of the pair, then the symmetric relations
            for kind, meaning in RELATIONS.items():
                if not is_symmetric(meaning):
                    relation(kind, left, right)
        for kind, meaning in RELATIONS.items():
            if is_symmetric(meaning):
                relation(kind, a, b)
        for x_edge in ("start", "stop"):
            for y_edge in ("start", "stop"):
                self._bounds(a, b, x_edge, y_edge, ra, rb, consider)

    def _bounds(self, a: str, b: str, x_edge: str, y_edge: str, ra: Rows, rb: Rows,
                consider: Callable[..., bool]) -> None:
        """``y(b) >= x(a) + L``, ``y(b) <= x(a) + U`` and, when both are tight around 0, ``equal``."""
        low = np.sort(_edge(rb, y_edge, "min") - _edge(ra, x_edge, "max"))
        high = -np.sort(-(_edge(rb, y_edge, "max") - _edge(ra, x_edge, "min")))
        lower_seen, lower_gap = _extreme(low, self.options.confidence)
        upper_seen, upper_gap = _extreme(high, self.options.confidence)
        lower = floor_to(lower_seen / 1000.0)
        upper = ceil_to(upper_seen / 1000.0)
        spread = float(high[0] - low[0])
        x_time = ir.SignalTime(a, x_edge)  # type: ignore[arg-type]
        tolerance = max(-lower, upper)
        if lower <= 0 <= upper and tolerance <= EQUAL_MAX_TOLERANCE:
            expr: ir.Expr = ir.Compare("=", x_time, ir.SignalTime(b, y_edge),  # type: ignore[arg-type]
                                       tolerance=to_ticks(tolerance))
            if consider("equal", f"{y_edge}_{b}_with_{x_edge}_{a}", expr,
                        _band(x_edge, y_edge, tolerance * 1000)):
                return
        info = BoundInfo(a, x_edge, b, y_edge, "lower", lower_seen, lower_gap, spread, lower * 1000)
        after = ir.Compare(">=", ir.SignalTime(b, y_edge), ir.SignalTime(a, x_edge, to_ticks(lower)))  # type: ignore[arg-type]
        consider("bound", f"{y_edge}_{b}_after_{x_edge}_{a}", after, _lower(x_edge, y_edge, lower * 1000),
                 bound=info)
        info = BoundInfo(a, x_edge, b, y_edge, "upper", upper_seen, upper_gap, spread, upper * 1000)
        before = ir.Compare("<=", ir.SignalTime(b, y_edge), ir.SignalTime(a, x_edge, to_ticks(upper)))  # type: ignore[arg-type]
        consider("bound", f"{y_edge}_{b}_by_{x_edge}_{a}", before, _upper(x_edge, y_edge, upper * 1000),
                 bound=info)

    def _cross_pairs(self, sa: SignalArrays, sb: SignalArrays) -> tuple[Ints, Ints] | None:
        """Index pairs (sequence of a, another sequence of b) for the baseline."""
        first, second = np.flatnonzero(sa.present), np.flatnonzero(sb.present)
        if len(first) == 0 or len(second) == 0:
            return None
        lefts, rights = [], []
        size = len(second)
        shifts = sorted({max(1, (size * k) // (BASELINE_SHIFTS + 1)) for k in range(1, BASELINE_SHIFTS + 1)})
        for shift in shifts:
            partner = second[(np.arange(len(first)) + shift) % size]
            keep = partner != first
            lefts.append(first[keep])
            rights.append(partner[keep])
        left, right = np.concatenate(lefts), np.concatenate(rights)
        return (left, right) if len(left) else None

    def _exact(self, kind: str, a: str, b: str, both: Ints) -> Bools:
        """``kind(a, b)`` in each sequence of ``both``, pair by pair."""
        sequences, holds = self.corpus.sequences, interval_test(kind)
        result = np.empty(len(both), dtype=bool)
        for position, index in enumerate(both):
            occurrences = sequences[int(index)].occurrences
            result[position] = all(holds(x, y) for x in occurrences[a] for y in occurrences[b])
        return result


def _extreme(ordered: Floats, confidence: float) -> tuple[float, float]:
    """The ``1 - confidence`` quantile of values sorted from the extreme inward, and the mean
    spacing of the :data:`SPACING_COUNT` values from there inward (0 for one value)."""
    start = int(np.floor((1 - confidence) * (len(ordered) - 1) + 1e-9))
    window = ordered[start:start + SPACING_COUNT]
    gap = abs(float(window[-1] - window[0])) / (len(window) - 1) if len(window) > 1 else 0.0
    return float(ordered[start]), gap


def _flip(holds: Holds, swapped: bool) -> Holds:
    return (lambda x, y: holds(y, x)) if swapped else holds


def _relation_holds(kind: str) -> Holds:
    """``kind`` for every pair, judged on the extreme values of each sequence: each bound
    ``x <= y`` as max x <= min y (exact for a conjunction; for a disjunction the corpus
    itself is checked pair by pair, :meth:`Miner._exact`)."""
    meaning = RELATIONS[kind]

    def bound_holds(bound: Bound[Endpoint], a: Rows, b: Rows) -> Bools:
        rows = {"left": a, "right": b}
        x = _edge(rows[bound.lower.side], bound.lower.edge, "max")
        y = _edge(rows[bound.upper.side], bound.upper.edge, "min")
        if bound.slack == STRICT:
            return x < y
        return x - y <= bound.limit(0) if bound.slack else x <= y

    def holds(a: Rows, b: Rows) -> Bools:
        results = [bound_holds(bound, a, b) for bound in meaning.bounds]
        combined = results[0]
        for result in results[1:]:
            combined = (combined & result) if meaning.joined == "and" else (combined | result)
        return combined

    return holds


def _lower(x_edge: str, y_edge: str, offset: float) -> Holds:
    return lambda a, b: _edge(b, y_edge, "min") - _edge(a, x_edge, "max") >= offset - 1e-6


def _upper(x_edge: str, y_edge: str, offset: float) -> Holds:
    return lambda a, b: _edge(b, y_edge, "max") - _edge(a, x_edge, "min") <= offset + 1e-6


def _band(x_edge: str, y_edge: str, tolerance: float) -> Holds:
    low, high = _lower(x_edge, y_edge, -tolerance), _upper(x_edge, y_edge, tolerance)
    return lambda a, b: low(a, b) & high(a, b)


def mine(corpus: Corpus, arrays: CorpusArrays, options: MiningOptions) -> list[Rule]:
    """Every rule that passes support, confidence and significance (before redundancy)."""
    return Miner(corpus, arrays, options).run()
