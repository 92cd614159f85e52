"""Prior draws (mse/ir/prior_draw.py) are written out for speed: every draw must stay the one
the prior's definition makes with the same random numbers.  The definition is spelled out here
with the standard library's distributions (random.expovariate, random.triangular) and
mse.ir.profile, and compared draw by draw, seed by seed."""

from __future__ import annotations

import dataclasses
import math
import random

import pytest

from mse.api import load
from mse.ir import model as ir
from mse.ir.prior_draw import PriorDraw, _occurrence
from mse.ir.profile import occurrence_probability, profile_at, start_rate
from mse.ir.schedule import TICKS_PER_SECOND, Occurrence, Schedule, to_ticks
from mse.resources import bundled_names


def _length(rng: random.Random, low: int, longest: int | None, start: int, duration: int) -> int:
    high = duration - start if longest is None else min(duration - start, longest)
    if high <= low:
        return low
    return round(rng.triangular(low, high, (low + high) / 2))


def _definition(model: ir.Model, duration: int, rng: random.Random) -> Schedule:
    """The prior as the module's docstring defines it, with no shortcut."""
    found: list[Occurrence] = []
    signals = [s for s in model.signals if not s.repetitive] + [s for s in model.signals if s.repetitive]
    for signal in signals:
        shortest = max(1, to_ticks(signal.min_duration))
        longest = None if signal.max_duration is None else to_ticks(signal.max_duration)
        last = duration - shortest
        if not signal.repetitive:
            occurs = occurrence_probability(signal) if last >= 0 else 0.0
            if rng.random() >= occurs:
                continue
            b = profile_at(signal, 0.0)
            slope = (profile_at(signal, last / duration) if last >= 0 else b) - b
            if abs(slope) >= 1e-12 * max(1.0, abs(b)):
                a = slope / 2
                target = rng.random() * (b + a)
                v = (-b + math.sqrt(max(0.0, b * b + 4 * a * target))) / (2 * a)
            else:
                v = rng.random()
            start = min(last, int(v * last))
            found.append(Occurrence(start, start + _length(rng, shortest, longest, start, duration), signal.id))
            continue
        never = signal.probability_start <= 0 and signal.probability_end <= 0
        peak = 0.0 if never or last < 0 else max(start_rate(signal, 0.0), start_rate(signal, 1.0))
        if peak <= 0:
            continue
        t, mine = 0.0, 0
        while signal.max_occurrences is None or mine < signal.max_occurrences:
            t += rng.expovariate(peak)
            start = math.ceil(t * TICKS_PER_SECOND)
            if start > last:
                break
            if rng.random() * peak > start_rate(signal, start / duration):
                continue
            stop = start + _length(rng, shortest, longest, start, duration)
            found.append(Occurrence(start, stop, signal.id))
            mine += 1
            t = stop / TICKS_PER_SECOND
    return Schedule.of(duration, found)


def test_the_occurrence_shortcut_sets_every_field() -> None:
    assert [f.name for f in dataclasses.fields(Occurrence)] == ["start", "stop", "signal"]
    made = _occurrence(3, 7, "smile")
    assert made == Occurrence(3, 7, "smile") and hash(made) == hash(Occurrence(3, 7, "smile"))
    assert type(made) is Occurrence


@pytest.mark.parametrize("name", bundled_names())
@pytest.mark.parametrize("seconds", [0.5, 3.0, 10.0, 30.0])
def test_draws_are_the_definitions_draws(name: str, seconds: float) -> None:
    model = load(name)
    duration = to_ticks(seconds)
    prior = PriorDraw(model, duration)
    fast, slow = random.Random(seconds), random.Random(seconds)
    for _ in range(150):
        assert prior.draw(fast) == _definition(model, duration, slow)
    assert fast.random() == slow.random()  # the same number of draws


def test_linear_profiles_and_limits_follow_the_definition() -> None:
    rng = random.Random(4)
    for _ in range(40):
        signals = tuple(
            ir.Signal(
                id=f"s{k}", modality="face", lexeme="x",
                probability_start=rng.choice([0.0, 0.2, 0.7, 1.0]), probability_end=rng.choice([0.0, 0.5, 1.0]),
                min_duration=rng.choice([0.001, 0.4, 2.0]), max_duration=rng.choice([None, 1.0, 6.0]),
                repetitivity=rng.choice([0, 1]), max_occurrences=rng.choice([None, 1, 3]),
            )
            for k in range(4)
        )
        model = ir.Model(name="m", signals=signals)
        duration = rng.choice([700, 5_000, 12_345])
        fast, slow = random.Random(duration), random.Random(duration)
        prior = PriorDraw(model, duration)
        for _ in range(30):
            assert prior.draw(fast) == _definition(model, duration, slow)
