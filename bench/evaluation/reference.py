"""The reference sampler: the target distribution of every sampler, drawn exactly.

docs/semantics.md ("Probabilities") names the target: the *prior* (each signal on its own,
mse/ir/profile.py) conditioned on the timeline being consistent.
:func:`mse.ir.prior_draw.prior_timeline` draws one timeline from the prior (the package's
definition, which the samplers' rejection stage, mse/solve/rejection.py, draws with too);
keeping the draws that the one evaluator accepts (:func:`mse.ir.evaluate.is_consistent`,
which stops at the first violation) is rejection sampling from the target
(:func:`sample_reference`).  It is exact and slow: it only works where enough draws are
consistent, which is what the ``acceptance`` it reports says.  Benches (``bench.evaluation.distribution``,
``bench.speed.sample --fidelity``) and tests (tests/test_distribution.py) use it.

:func:`statistics` gives what the bench table compares: the mean number of once-only signals
per timeline and, per signal, its *rate*: for a once-only signal the fraction of timelines
where it occurs, for a repetitive one its occurrences per 10 s of timeline (so that rates of
different durations compare).  :func:`prior_statistics` is the same for the prior alone, in
closed form where profile.py gives one (tests check the sampler against it).
"""

from __future__ import annotations

import random
import time
from collections.abc import Sequence
from dataclasses import dataclass

from mse.ir import model as ir
from mse.ir.evaluate import is_consistent
from mse.ir.prior_draw import PriorDraw
from mse.ir.profile import mean_relative_start, occurrence_probability
from mse.ir.schedule import TICKS_PER_SECOND, Schedule, to_ticks

#: Repetitive rates are counted per this many seconds of timeline.
RATE_SECONDS = 10.0


@dataclass(frozen=True)
class Reference:
    """Consistent draws of the prior (``accepted``) out of ``draws``."""

    accepted: tuple[Schedule, ...]
    draws: int

    @property
    def acceptance(self) -> float:
        return len(self.accepted) / self.draws if self.draws else 0.0


def sample_reference(model: ir.Model, duration: float, *, wanted: int, seed: int, max_draws: int,
                     max_seconds: float | None = None) -> Reference:
    """Rejection sampling of the target: prior draws until ``wanted`` are consistent, at most
    ``max_draws`` draws (and ``max_seconds`` of wall time).  Draw i uses the stream of one
    ``random.Random(seed)``, so a seed fixes the result."""
    rng = random.Random(seed)
    prior = PriorDraw(model, to_ticks(duration))
    accepted: list[Schedule] = []
    draws = 0
    began = time.monotonic()
    while draws < max_draws and len(accepted) < wanted:
        if max_seconds is not None and draws % 64 == 0 and time.monotonic() - began > max_seconds:
            break
        draws += 1
        schedule = prior.draw(rng)
        if is_consistent(model, schedule):
            accepted.append(schedule)
    return Reference(tuple(accepted), draws)


def sample_chain_reference(model: ir.Model, duration: float, *, wanted: int, seed: int, chains: int = 4,
                           burn: int = 20, thin: int = 2) -> Reference:
    """The target by its Markov chain, where rejection accepts too few
    (:func:`mse.solve.chain.chain_samples`: ``chains`` chains from the walk's timelines, ``burn``
    sweeps dropped, then one timeline every ``thin`` sweeps).  ``draws`` counts the sweeps run."""
    from mse.solve.chain import chain_samples

    kept, sweeps = chain_samples(model, duration, wanted, seed, chains=chains, burn=burn, thin=thin)
    return Reference(tuple(kept), sweeps)


@dataclass(frozen=True)
class Statistics:
    """What the distribution bench compares (see the module's docstring)."""

    once_per_timeline: float
    rate: dict[str, float]
    start: dict[str, float | None]  # mean start (s) of the signal's occurrences
    count: int


def statistics(model: ir.Model, schedules: Sequence[Schedule], duration: float) -> Statistics:
    counts = {s.id: 0 for s in model.signals}
    starts: dict[str, list[int]] = {s.id: [] for s in model.signals}
    once = 0
    repetitive = {s.id for s in model.signals if s.repetitive}
    for schedule in schedules:
        seen: set[str] = set()
        for occurrence in schedule.occurrences:
            name = occurrence.signal
            starts[name].append(occurrence.start)
            if name in repetitive:
                counts[name] += 1
            elif name not in seen:
                counts[name] += 1
                once += 1
            seen.add(name)
    total = max(1, len(schedules))
    scale = {s.id: (RATE_SECONDS / duration if s.repetitive else 1.0) for s in model.signals}
    return Statistics(
        once / total,
        {k: v / total * scale[k] for k, v in counts.items()},
        {k: (sum(v) / len(v) / TICKS_PER_SECOND if v else None) for k, v in starts.items()},
        len(schedules),
    )


def prior_statistics(model: ir.Model, duration: float) -> Statistics:
    """The prior's own statistics in closed form: once-only signals' rates and mean starts
    (profile.py; the mean start over the whole span, exact when ``min_duration`` is small
    against the duration); repetitive signals: NaN (no closed form with lengths)."""
    rate: dict[str, float] = {}
    start: dict[str, float | None] = {}
    for signal in model.signals:
        if signal.repetitive:
            rate[signal.id], start[signal.id] = float("nan"), None
        else:
            rate[signal.id] = occurrence_probability(signal)
            start[signal.id] = mean_relative_start(signal) * duration
    once = sum(v for s, v in rate.items() if not model.signal(s).repetitive)
    return Statistics(once, rate, start, 0)
