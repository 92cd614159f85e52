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

Consistency is decided by the one evaluator: the constraints that mention the moved signals
(the others cannot change truth value; sub-models built once per model) by
:func:`mse.ir.evaluate.constraints_hold` on the run's per-signal pools, which the chain keeps
up to date instead of regrouping the timeline per move (at an hour the regrouping was
nearly all of a run's cost), and the moved signals' exclusive modalities by
:func:`mse.ir.evaluate.is_consistent` on the occurrences that meet the changed span.
``--forbid`` signals are never drawn, a move that leaves a ``--require`` signal absent is
rejected.

The number of moves is fixed by the set and the duration (:data:`SWEEPS` sweeps, each one
whole move per block and, for a block with repetitive signals, as many window moves as
windows fit in the timeline), never by wall time: a seed gives the same timeline anywhere.
"""

from __future__ import annotations

import bisect
import math
import random
import weakref
from collections.abc import Collection, Iterable
from dataclasses import replace

from mse.ir import model as ir
from mse.ir.evaluate import constraints_hold, is_consistent
from mse.ir.prior_draw import RepetitiveDensity, prior_signal
from mse.ir.profile import start_rate
from mse.ir.schedule import TICKS_PER_SECOND, Occurrence, Schedule

#: Sweeps after the start (each: every block once, and its windows at long durations) ...
SWEEPS = 30
#: ... up to this duration (seconds); past it a sweep holds as many windows as fit in the
#: timeline (its cost grows with the duration): SWEEPS x SWEEPS_SECONDS / duration sweeps, at
#: least MIN_SWEEPS (an hour: 2 sweeps, 0.1-0.3 s of CPU each on the chained sets).
SWEEPS_SECONDS = 60.0
MIN_SWEEPS = 2
#: Windowed sweeps at any duration when the start is CP-SAT's timeline: past SWEEPS_SECONDS
#: it packs repetitive signals far denser than the prior where the walk does not (anxiety at
#: an hour: its two gaze signals, an exclusive modality, 0.85 per 10 s above the target from
#: CP-SAT, within 0.07 from the walk; from CP-SAT 2 sweeps left 0.61, 8 left 0.26, 20 left
#: 0.06), and its own solve costs about 16 s of CPU there, against 1-9 s for these sweeps.
FAR_SWEEPS = SWEEPS
#: A window holds on average about this many cycles (start, run, free) of its slowest signal,
#: up to SWEEPS_SECONDS: small windows are often accepted, so that a chain leaves a mode (e.g.
#: the chains of equalities of Greta's tension: from CP-SAT's timeline, 30 sweeps of windows of
#: 2 cycles left a signal's rate 0.7 per 10 s from the target, of 0.5 cycle 0.1) ...
WINDOW_CYCLES = 0.5
#: ... past it, fewer larger ones.
LONG_WINDOW_CYCLES = 2.0
#: Window moves per sweep of a block that holds once-only signals as well (Greta's regret at
#: 60 s: 13 such blocks of 42 windows each made a timeline cost 1 s; at 10 s no block has more).
MIXED_WINDOWS = 8
#: Checks (moves that reach the evaluator) one run may make; past it the blocks with windows
#: stop moving and the others go on.  A check reads the moved signals' constraints on the
#: run's pools (mse.ir.evaluate.constraints_hold: O(1) per conjunctive atom, one merge per
#: disjointness), 20-200 us, so this is a bound on a run's cost (about 5-40 s) that no
#: bundled or Greta set reaches (an hour of Greta's tension makes about 8,600 checks).  Counted,
#: never timed: a seed gives the same timeline anywhere.
CHECK_BUDGET = 200_000

Spans = list[Occurrence]
_Pool = list[tuple[int, int]]
#: A move of one signal: its occurrences ``[i:j]`` (in start order) replaced by these.
_Splice = tuple[int, int, Spans]


def _start(occurrence: Occurrence) -> int:
    return occurrence.start


def _stop(occurrence: Occurrence) -> int:
    return occurrence.stop


class _Block:
    """Signals moved together, the sub-model that checks a move of them and its signals."""

    __slots__ = ("free", "local", "names", "relevant", "structure", "submodel", "window", "windows")

    def __init__(self, model: ir.Model, names: tuple[str, ...], window: int) -> None:
        self.names = names
        moved = set(names)
        constraints = tuple(c for c in model.constraints if ir.mentioned_signals(c.expr) & moved)
        exclusive = model.exclusive_modalities
        modalities = {model.signal(n).modality for n in names} & exclusive
        relevant = set(moved)
        for constraint in constraints:
            relevant |= ir.mentioned_signals(constraint.expr)
        #: Signals whose every occurrence the constraints' check reads (the moved ones and
        #: those their constraints mention) ...
        self.relevant = tuple(sorted(relevant))
        #: ... and those that share an exclusive modality with a moved one: only their
        #: occurrences that meet the changed time span can overlap a new one (the state was
        #: consistent before the move).
        self.local = tuple(sorted({s.id for s in model.signals if s.modality in modalities} - moved))
        self.submodel = replace(model, constraints=constraints)
        #: The per-signal rules alone (exclusive modalities), checked on the changed span.
        self.structure = replace(model, constraints=()) if modalities else None
        #: No constraint and no exclusive modality touches the block: every prior draw of it is
        #: consistent with the rest (lengths, counts and order are the prior's by construction).
        self.free = not constraints and not self.local
        #: Window length in ticks (0: whole redraws only) and window moves per sweep.
        self.window = window
        self.windows = 0


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
        for block in self.blocks:
            if block.free:
                # Its whole redraw is always kept: an exact draw of its conditional law, which
                # windows could only repeat.
                block.window = 0
            if block.window:
                # As many windows as fit; a block that also moves once-only signals (redrawn
                # whole at each of its window moves) at most MIXED_WINDOWS: their own moves
                # and the repetitive signals' blocks do most of the mixing.
                fit = math.ceil(duration / block.window)
                mixed = any(name not in self.densities for name in block.names)
                block.windows = min(fit, MIXED_WINDOWS) if mixed else fit

    def _window(self, names: tuple[str, ...]) -> int:
        """Window length for a block: WINDOW_CYCLES (LONG_WINDOW_CYCLES) mean cycles of its
        slowest repetitive signal; 0 when the block has none or a window would cover the
        timeline."""
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
            cycles = WINDOW_CYCLES if self.duration <= SWEEPS_SECONDS * TICKS_PER_SECOND else LONG_WINDOW_CYCLES
            longest = max(longest, cycles * (1 / rate + length) * TICKS_PER_SECOND)
        if longest <= 0 or longest >= self.duration:
            return 0
        return max(1, int(longest))

    def sweeps(self) -> int:
        """Sweeps of one run: a deterministic function of the duration."""
        seconds = self.duration / TICKS_PER_SECOND
        if seconds <= SWEEPS_SECONDS:
            return SWEEPS
        return max(MIN_SWEEPS, math.ceil(SWEEPS * SWEEPS_SECONDS / seconds))

    def run(self, schedule: Schedule, rng: random.Random, sweeps: int | None = None) -> Schedule:
        """``schedule`` (consistent) after ``sweeps`` sweeps of the blocks with windows
        (default: :meth:`sweeps`); the other blocks (once-only signals, and repetitive ones
        where no window fits), whose moves cost no more at an hour than at 10 s, move
        SWEEPS / :meth:`sweeps` times as often (at an hour 15 times: 2 sweeps of them left
        Greta's relief 0.4 of a signal per timeline from the target)."""
        windowed = self.sweeps() if sweeps is None else sweeps
        total = max(windowed, min(SWEEPS, windowed * SWEEPS // self.sweeps()))
        state: dict[str, Spans] = {name: [] for name in self.model.signal_by_id}
        for occurrence in sorted(schedule.occurrences):
            state.setdefault(occurrence.signal, []).append(occurrence)
        run = _Run(state)
        for index in range(total):
            with_windows = index * windowed // total != (index + 1) * windowed // total
            for block in self.blocks:
                if block.window and (not with_windows or run.spent >= CHECK_BUDGET):
                    continue
                self._whole(block, run, rng)
                for _ in range(block.windows):
                    self._windowed(block, run, rng)
        return Schedule.of(schedule.duration, (o for spans in state.values() for o in spans))

    # -- moves -------------------------------------------------------------------------------
    def _whole(self, block: _Block, run: _Run, rng: random.Random) -> None:
        proposal: dict[str, _Splice] = {}
        for name in block.names:
            draw = self.draws[name].draw(rng)
            drawn = draw if isinstance(draw, list) else ([] if draw is None else [draw])
            proposal[name] = (0, len(run.state[name]), drawn)
        self._accept_if_consistent(block, run, proposal, None)

    def _windowed(self, block: _Block, run: _Run, rng: random.Random) -> None:
        state = run.state
        duration, length = self.duration, block.window
        first = rng.randrange(-length + 1, duration)
        low, high = max(1, first), first + length - 1  # starts in [low, high]
        proposal: dict[str, _Splice] = {}
        changed: Spans = []  # occurrences the move removes or adds
        log_ratio = 0.0
        for name in block.names:
            density = self.densities.get(name)
            spans = state[name]
            if density is None:  # a once-only partner: redrawn whole from the prior (ratio 1)
                drawn = self.draws[name].draw(rng)
                proposal[name] = (0, len(spans), [] if drawn is None else [drawn])  # type: ignore[list-item]
                changed.extend(spans)
                changed.extend(proposal[name][2])
                continue
            # The occurrences that start in the window, spans[i:j], are redrawn; the lists are
            # only cut once a move passes its density ratio (an hour holds ~1,000 of a signal).
            count = len(spans)
            i = bisect.bisect_left(spans, low, key=_start)
            j = bisect.bisect_right(spans, high, key=_start)
            top = min(high, density.last)
            free = max(spans[i - 1].stop if i else 0, low - 1)
            remaining = None if density.limit is None else density.limit - i - (count - j)
            if remaining is not None and remaining < j - i:  # cannot happen on a valid state
                return
            after = (spans[j], spans[-1]) if j < count else None
            drawn_inside = density.run(rng, free, top, remaining)
            gain = density.window_term(free, drawn_inside, after, top, remaining, count - (j - i) + len(drawn_inside))
            if gain is None:  # overlaps the next kept occurrence: density 0
                return
            inside = spans[i:j]
            kept = density.window_term(free, inside, after, top, remaining, count)
            # (None: the start, the walk's or CP-SAT's, is outside the prior's support, e.g. two
            # occurrences back to back; any consistent proposal is then accepted.)
            log_ratio += math.inf if kept is None else gain - kept
            proposal[name] = (i, j, drawn_inside)
            changed.extend(inside)
            changed.extend(drawn_inside)
        if log_ratio < 0 and rng.random() >= math.exp(log_ratio):
            return
        span = (min(o.start for o in changed), max(o.stop for o in changed)) if changed else None
        self._accept_if_consistent(block, run, proposal, span)

    def _accept_if_consistent(self, block: _Block, run: _Run, proposal: dict[str, _Splice],
                              span: tuple[int, int] | None) -> bool:
        """Apply ``proposal`` (per moved signal: its occurrences ``[i:j]`` replaced by new
        ones) iff the timeline stays consistent; ``span``: from the first start to the last
        stop of the occurrences it removes or adds (None: not known)."""
        state = run.state
        if all(drawn == state[name][i:j] for name, (i, j, drawn) in proposal.items()):
            return True  # nothing changes (often: an absent once-only signal drawn absent again)
        for name, (i, j, drawn) in proposal.items():
            if not drawn and name in self.require and j - i == len(state[name]):
                return False
        pools: dict[str, _Pool] = {}
        if not block.free:
            if block.structure is not None and not self._structure_holds(block, run, proposal, span):
                return False
            if block.submodel.constraints:
                for name, (i, j, drawn) in proposal.items():
                    pool = run.pools[name]
                    pools[name] = pool[:i] + [(o.start, o.stop) for o in drawn] + pool[j:]
                view = {name: pools[name] if name in pools else run.pools[name] for name in block.relevant}
                run.spent += 1
                if not constraints_hold(block.submodel, view, self.duration):
                    return False
        for name, (i, j, drawn) in proposal.items():
            state[name][i:j] = drawn
            if name in pools:
                run.pools[name] = pools[name]
            else:
                run.pools[name][i:j] = [(o.start, o.stop) for o in drawn]
        return True

    def _structure_holds(self, block: _Block, run: _Run, proposal: dict[str, _Splice],
                         span: tuple[int, int] | None) -> bool:
        """The exclusive modalities on the span the move changes: a new occurrence can only
        overlap an occurrence that meets that span (the state was consistent)."""
        state = run.state
        if span is None:
            changed = [o for name, (i, j, drawn) in proposal.items()
                       for o in set(drawn).symmetric_difference(state[name][i:j])]
            span = (min(o.start for o in changed), max(o.stop for o in changed))
        low, high = span
        occurrences: list[Occurrence] = []
        for name in (*proposal, *block.local):
            spans = state[name]
            if name in proposal:
                i, j, drawn = proposal[name]
                spans = spans[:i] + drawn + spans[j:]
            occurrences.extend(spans[bisect.bisect_right(spans, low, key=_stop):
                                     bisect.bisect_left(spans, high, key=_start)])
        run.spent += 1
        assert block.structure is not None
        return is_consistent(block.structure, Schedule(self.duration, tuple(occurrences)))


class _Run:
    """One run's timeline: per signal its occurrences (sorted) and the same as pools
    (``(start, stop)``, what the evaluator's constraint check reads), and the checks it has
    made (:data:`CHECK_BUDGET`)."""

    __slots__ = ("pools", "spent", "state")

    def __init__(self, state: dict[str, Spans]) -> None:
        self.state = state
        self.pools: dict[str, _Pool] = {name: [(o.start, o.stop) for o in spans] for name, spans in state.items()}
        self.spent = 0


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
        chain = entry[1][key] = Chain(model, duration, key[1], key[2])
    return chain


def chain_samples(model: ir.Model, duration: float, count: int, seed: int, *, chains: int = 4,
                  burn: int = SWEEPS, thin: int = 1) -> tuple[list[Schedule], int]:
    """``count`` timelines of the chain's stationary law (the target) from a few long chains,
    and the sweeps run: ``chains`` chains, each from another consistent timeline (the default
    sampler without its rejection stage, so without the chain: the walk's, or CP-SAT's, seeds
    ``seed + i``), ``burn`` sweeps dropped, then one timeline every ``thin`` sweeps.  Kept
    timelines of one chain are correlated, but their rates estimate the target's for a small
    part of the sweeps that ``count`` chained timelines cost (one burn-in per chain instead
    of one per timeline): the bench's reference where rejection accepts too few, and what
    ``mse learn``'s calibration measures where the default sampler chains."""
    from mse.ir.schedule import to_ticks
    from mse.solve.protocol import SolveRequest, get_solver

    chain = Chain(model, to_ticks(duration))
    solver = get_solver("greedy")
    kept: list[Schedule] = []
    sweeps = 0
    for index in range(chains):
        share = count // chains + (1 if index < count % chains else 0)
        if not share:
            continue
        request = SolveRequest(duration=duration, seed=seed + index, rejection=False)
        state = solver.solve(model, request).solutions[0].schedule
        rng = random.Random(f"chain-reference/{seed}/{index}")
        state = chain.run(state, rng, burn)
        sweeps += burn
        for _ in range(share):
            state = chain.run(state, rng, thin)
            sweeps += thin
            kept.append(state)
    return kept, sweeps


def chained(model: ir.Model, schedule: Schedule, seed: int, absent: Iterable[str] = (),
            require: Iterable[str] = (), *, far: bool = False) -> Schedule:
    """``schedule`` (consistent) after the chain's moves for ``seed`` (its own random stream);
    ``far``: the start is CP-SAT's timeline, which gets :data:`SWEEPS` sweeps at any duration
    (:data:`FAR_SWEEPS`)."""
    chain = chain_for(model, schedule.duration, absent, require)
    sweeps = max(chain.sweeps(), FAR_SWEEPS) if far else None
    return chain.run(schedule, random.Random(f"chain/{seed}"), sweeps)


