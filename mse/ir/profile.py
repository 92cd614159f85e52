"""What ``probability_start`` and ``probability_end`` mean: the one definition every solver,
the learner and the benches use (docs/semantics.md, "Probabilities").

A signal's *profile* is the straight line from ``probability_start`` at the beginning of the
expression to ``probability_end`` at its end, over the expression's *relative time*
``u = t / D`` (``D`` the timeline's duration)::

    p(u) = probability_start + (probability_end - probability_start) * u,   0 <= u <= 1

* **A signal that occurs at most once** (``repetitivity="0"``) occurs with probability
  ``mean(p) = (probability_start + probability_end) / 2`` and, when it does, its start is
  distributed over the expression with density proportional to ``p(u)``.  So ``p(u) du`` is
  the probability that it starts within ``du`` of relative time ``u``: ``0.2``/``0.2`` occurs
  in about 20 % of timelines, at a uniformly drawn time; ``0.9``/``0.1`` in half of them,
  mostly early; ``0``/``0`` never.  Neither the timeline's duration nor the time step changes
  any of this.
* **A repetitive signal** starts, at each moment it is free (not running, and below
  ``max_occurrences``), with probability ``p(u)`` within the next free second: a rate of
  ``-ln(1 - p(u))`` starts per second (:func:`start_rate`).  A long timeline is as dense as
  a short one.
* **Durations** are drawn from the triangular distribution on ``[min_duration, max]`` with the
  mode at the midpoint; ``max`` is ``max_duration`` capped by the end of the timeline (an
  unbounded ``max_duration`` reaches the end).

This is the *prior*: each signal on its own, before constraints.  A sampled timeline follows
the prior **conditioned on being consistent** (every constraint holds, exclusive modalities do
not overlap): drawing from the prior and keeping only consistent timelines would give the same
distribution: the samplers do exactly that first where it is cheap (:mod:`mse.ir.prior_draw`
draws the prior, :mod:`mse.solve.rejection` keeps the first consistent draw); elsewhere the
greedy walk approximates that conditional, and CP-SAT's default objective too;
``bench.evaluation.distribution`` measures them against it.  The control condition
(``--mode constraint-less``) is the prior conditioned on violating at least one constraint.
"""

from __future__ import annotations

import math

from mse.ir.model import Signal

#: A free second's start probability above which the rate is capped (p = 1: about 14 starts
#: per free second, the signal restarts as soon as it is free).
MAX_PROBABILITY = 1.0 - 1e-6
#: Length (seconds) of the "free second" in which a repetitive signal starts with probability p(u).
RATE_UNIT = 1.0


def profile_at(signal: Signal, u: float) -> float:
    """``p(u)`` at relative time ``u`` (clamped to [0, 1])."""
    u = min(1.0, max(0.0, u))
    return signal.probability_start + (signal.probability_end - signal.probability_start) * u


def occurrence_probability(signal: Signal) -> float:
    """Probability that a signal occurring at most once occurs at all (before constraints)."""
    return (signal.probability_start + signal.probability_end) / 2.0


def start_weight(signal: Signal, u: float) -> float:
    """Unnormalised density of a once-only signal's start at relative time ``u``."""
    return profile_at(signal, u)


def mean_relative_start(signal: Signal) -> float:
    """Expected relative start ``E[u]`` of a once-only signal that occurs (0.5 for a flat profile).

    With density proportional to ``a + (b - a) u`` on [0, 1]: ``E[u] = (a + 2b) / (3 (a + b))``.
    """
    a, b = signal.probability_start, signal.probability_end
    if a + b <= 0:
        return 0.5
    return (a + 2 * b) / (3 * (a + b))


def start_rate(signal: Signal, u: float) -> float:
    """Starts per second of a free repetitive signal at relative time ``u``: the rate at which
    a free second holds a start with probability ``p(u)`` (``p = 1``: a start at once, capped)."""
    return -math.log1p(-min(profile_at(signal, u), MAX_PROBABILITY)) / RATE_UNIT


def never_occurs(signal: Signal) -> bool:
    """Both probabilities are 0: the signal is absent from every default sample (it may still
    occur when a constraint, a ``--require`` or a pin demands it)."""
    return signal.probability_start <= 0.0 and signal.probability_end <= 0.0
