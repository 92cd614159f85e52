"""The chain stage: a Markov chain whose stationary law is exactly the target (docs/sampler.md,
"Chain").

The target of every sampler is the prior (:mod:`mse.ir.prior_draw`, signals independent)
conditioned on consistency.  Where rejection would almost never draw a consistent timeline
(its pilot found it too costly), the walk's timeline (or CP-SAT's) starts this chain:
Metropolis within Gibbs with *prior proposals*.  A move picks a *block* — one signal, or the
signals one constraint links (redrawn at once: equalities and tight chains need it) — and
redraws it from the prior given the rest of the timeline:

* a once-only signal or a whole repetitive signal: a fresh prior draw of it.  The proposal is
  the target's own conditional before the constraints, so the Metropolis-Hastings ratio is 1
  on consistent timelines: the move is kept iff the timeline stays consistent;
* a repetitive signal's occurrences whose starts fall in a time *window* ``[a, b]`` (at long
  durations, where a whole redraw is never consistent): the signal's Poisson process with
  dead time run from its state at ``a`` (free since the last kept stop) up to ``b``, and the
  exact ratio of target and proposal densities (:func:`mse.ir.prior_draw.rate_integral`): the
  terms that differ are the free time after the window up to the next kept start (or the end)
  and whether the limit on occurrences was reached.  Times and windows are drawn whatever the
  state, so every move leaves the target invariant, and so does any sequence of them.

Consistency is decided by the one evaluator (:func:`mse.ir.evaluate.is_consistent`) on the
sub-model of the constraints that mention the moved signals (the others cannot change truth
value), over the occurrences of the signals those constraints and the moved signals'
exclusive modalities name; the sub-models are built once per model.  ``--forbid`` signals are
never drawn, a move that leaves a ``--require`` signal absent is rejected.

The number of moves is fixed by the set and the duration (:data:`SWEEPS` sweeps, each one
whole move per block and, for a block with repetitive signals, as many window moves as
windows fit in the timeline), never by wall time: a seed gives the same timeline anywhere.
"""

from __future__ import annotations

import math
import random
import weakref
from collections.abc import Collection, Iterable
from dataclasses import replace

from mse.ir import model as ir
from mse.ir.evaluate import is_consistent
from mse.ir.prior_draw import RepetitiveDensity, prior_signal
from mse.ir.profile import start_rate
from mse.ir.schedule import TICKS_PER_SECOND, Occurrence, Schedule

#: Sweeps after the start (each: every block once, and its windows at long durations).
SWEEPS = 10
#: A window holds on average about this many cycles (start, run, free) of its slowest signal.
WINDOW_CYCLES = 2.0

Spans = list[Occurrence]


class _Block:
    """Signals moved together, the sub-model that checks a move of them and its signals."""

    __slots__ = ("names", "relevant", "submodel", "window")

    def __init__(self, model: ir.Model, names: tuple[str, ...], window: int) -> None:
        self.names = names
        moved = set(names)
        constraints = tuple(c for c in model.constraints if ir.mentioned_signals(c.expr) & moved)
        exclusive = model.exclusive_modalities
        modalities = {model.signal(n).modality for n in names} & exclusive
        relevant = set(moved)
        for constraint in constraints:
            relevant |= ir.mentioned_signals(constraint.expr)
        relevant |= {s.id for s in model.signals if s.modality in modalities}
        self.relevant = tuple(sorted(relevant))
        self.submodel = replace(model, constraints=constraints)
        #: Window length in ticks (0: whole redraws only).
        self.window = window


class Chain:
    """The chain for one model, duration (ticks), forbidden and required signals."""

    def __init__(self, model: ir.Model, duration: int, absent: Collection[str] = (),
                 require: Collection[str] = ()) -> None:
        self.model, self.duration = model, duration
        self.require = frozenset(require)
        kept = [s for s in model.signals if s.id not in set(absent)]
        self.draws = {s.id: prior_signal(s, duration) for s in kept}
        self.densities = {s.id: RepetitiveDensity(s, duration) for s in kept if s.repetitive}
        blocks: list[tuple[str, ...]] = [(s.id,) for s in kept]
        known = set(blocks)
        names = set(self.draws)
        for constraint in model.constraints:
            linked = tuple(sorted(ir.mentioned_signals(constraint.expr) & names))
            if len(linked) > 1 and linked not in known:
                known.add(linked)
                blocks.append(linked)
        self.blocks = tuple(_Block(model, block, self._window(block)) for block in blocks)

    def _window(self, names: tuple[str, ...]) -> int:
        """Window length for a block: WINDOW_CYCLES mean cycles of its slowest repetitive
        signal; 0 when the block has none or a window would cover most of the timeline."""
        longest = 0.0
        for name in names:
            density = self.densities.get(name)
            if density is None:
                continue
            signal = self.model.signal(name)
            rate = max(1e-9, 0.5 * (start_rate(signal, 0.0) + start_rate(signal, 1.0)))
            draw = self.draws[name]
            length = draw.shortest / TICKS_PER_SECOND if draw.longest is None else (
                (draw.shortest + draw.longest) / 2 / TICKS_PER_SECOND)
            longest = max(longest, WINDOW_CYCLES * (1 / rate + length) * TICKS_PER_SECOND)
        if longest <= 0 or longest * 2 >= self.duration:
            return 0
        return max(1, int(longest))

    def moves(self) -> int:
        """Moves of one run: a deterministic function of the set and the duration."""
        per_sweep = 0
        for block in self.blocks:
            per_sweep += 1 + (math.ceil(self.duration / block.window) if block.window else 0)
        return SWEEPS * per_sweep

    def run(self, schedule: Schedule, rng: random.Random, sweeps: int = SWEEPS) -> Schedule:
        """``schedule`` (consistent) after ``sweeps`` sweeps of the chain."""
        state: dict[str, Spans] = {name: [] for name in self.model.signal_by_id}
        for occurrence in sorted(schedule.occurrences):
            state.setdefault(occurrence.signal, []).append(occurrence)
        for _ in range(sweeps):
            for block in self.blocks:
                self._whole(block, state, rng)
                if block.window:
                    for _ in range(math.ceil(self.duration / block.window)):
                        self._windowed(block, state, rng)
        return Schedule.of(schedule.duration, (o for spans in state.values() for o in spans))

    # -- moves -------------------------------------------------------------------------------
    def _whole(self, block: _Block, state: dict[str, Spans], rng: random.Random) -> None:
        proposal: dict[str, Spans] = {}
        for name in block.names:
            draw = self.draws[name].draw(rng)
            proposal[name] = draw if isinstance(draw, list) else ([] if draw is None else [draw])
        self._accept_if_consistent(block, state, proposal)

    def _windowed(self, block: _Block, state: dict[str, Spans], rng: random.Random) -> None:
        duration, length = self.duration, block.window
        first = rng.randrange(-length + 1, duration)
        low, high = max(1, first), first + length - 1  # starts in [low, high]
        proposal: dict[str, Spans] = {}
        log_ratio = 0.0
        for name in block.names:
            density = self.densities.get(name)
            if density is None:  # a once-only partner: redrawn whole from the prior (ratio 1)
                drawn = self.draws[name].draw(rng)
                proposal[name] = [] if drawn is None else [drawn]  # type: ignore[list-item]
                continue
            spans = state[name]
            before = [o for o in spans if o.start < low]
            inside = [o for o in spans if low <= o.start <= high]
            after = [o for o in spans if o.start > high]
            top = min(high, density.last)
            free = max(before[-1].stop if before else 0, low - 1)
            remaining = None if density.limit is None else density.limit - len(before) - len(after)
            if remaining is not None and remaining < len(inside):  # cannot happen on a valid state
                return
            drawn_inside = density.run(rng, free, top, remaining)
            new = before + drawn_inside + after
            gain = density.window_term(free, drawn_inside, after, top, remaining, len(new))
            if gain is None:  # overlaps the next kept occurrence: density 0
                return
            log_ratio += gain - density.window_term(free, inside, after, top, remaining, len(spans))  # type: ignore[operator]
            proposal[name] = new
        if log_ratio < 0 and rng.random() >= math.exp(log_ratio):
            return
        self._accept_if_consistent(block, state, proposal)

    def _accept_if_consistent(self, block: _Block, state: dict[str, Spans], proposal: dict[str, Spans]) -> bool:
        for name, spans in proposal.items():
            if not spans and name in self.require:
                return False
        occurrences: list[Occurrence] = []
        for name in block.relevant:
            occurrences.extend(proposal[name] if name in proposal else state.get(name, ()))
        if not is_consistent(block.submodel, Schedule(self.duration, tuple(occurrences))):
            return False
        state.update(proposal)
        return True


# One chain per model object, duration and request (identity, as the evaluator's checkers).
_CHAINS: dict[int, tuple[weakref.ref[ir.Model], dict[tuple[object, ...], Chain]]] = {}
_CHAINS_LIMIT = 64


def chain_for(model: ir.Model, duration: int, absent: Iterable[str] = (), require: Iterable[str] = ()) -> Chain:
    """The chain of ``model`` for this duration and request (built once, kept per model)."""
    entry = _CHAINS.get(id(model))
    if entry is None or entry[0]() is not model:
        if len(_CHAINS) >= _CHAINS_LIMIT:
            _CHAINS.clear()
        entry = _CHAINS[id(model)] = (weakref.ref(model), {})
    key = (duration, frozenset(absent), frozenset(require))
    chain = entry[1].get(key)
    if chain is None:
        if len(entry[1]) >= _CHAINS_LIMIT:
            entry[1].clear()
        chain = entry[1][key] = Chain(model, duration, key[1], key[2])  # type: ignore[arg-type]
    return chain


def chained(model: ir.Model, schedule: Schedule, seed: int, absent: Iterable[str] = (),
            require: Iterable[str] = ()) -> Schedule:
    """``schedule`` (consistent) after the chain's moves for ``seed`` (its own random stream)."""
    chain = chain_for(model, schedule.duration, absent, require)
    return chain.run(schedule, random.Random(f"chain/{seed}"))


