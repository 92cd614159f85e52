"""Per-signal arrays over the sequences of a corpus (numpy), shared by every learner step.

For a relational atom to hold, its relation must hold for *every* combination of
occurrences (docs/semantics.md); for the relations and comparisons the miner uses that is
a statement about extremes (``precedes(a, b)`` for all pairs iff the last stop of ``a`` is
at most the first start of ``b``), so four numbers per signal and sequence suffice:
the first and last start, the first and last stop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mse.learn.corpus import Corpus

Floats = npt.NDArray[np.float64]
Bools = npt.NDArray[np.bool_]
Ints = npt.NDArray[np.int64]


@dataclass(frozen=True)
class SignalArrays:
    """One signal over the n sequences (times in ms; NaN where the signal is absent)."""

    present: Bools
    count: Ints
    start_min: Floats
    start_max: Floats
    stop_min: Floats
    stop_max: Floats
    lengths: Floats  # every occurrence's length (ms)
    relative_starts: Floats  # every occurrence's start / its sequence's duration

    def edge(self, edge: str, extreme: str) -> Floats:
        """``start``/``stop`` and ``min``/``max``."""
        return {
            ("start", "min"): self.start_min,
            ("start", "max"): self.start_max,
            ("stop", "min"): self.stop_min,
            ("stop", "max"): self.stop_max,
        }[(edge, extreme)]


@dataclass(frozen=True)
class CorpusArrays:
    durations: Floats  # ms, per sequence
    signals: dict[str, SignalArrays]

    @property
    def size(self) -> int:
        return len(self.durations)


def corpus_arrays(corpus: Corpus) -> CorpusArrays:
    n = len(corpus.sequences)
    durations = np.array([s.duration for s in corpus.sequences], dtype=np.float64)
    signals: dict[str, SignalArrays] = {}
    for signal_id in corpus.signals:
        count = np.zeros(n, dtype=np.int64)
        extremes = np.full((4, n), np.nan)
        lengths: list[int] = []
        relative: list[float] = []
        for index, sequence in enumerate(corpus.sequences):
            occurrences = sequence.occurrences.get(signal_id)
            if not occurrences:
                continue
            count[index] = len(occurrences)
            starts = [o[0] for o in occurrences]
            stops = [o[1] for o in occurrences]
            extremes[:, index] = (min(starts), max(starts), min(stops), max(stops))
            lengths.extend(stop - start for start, stop in occurrences)
            relative.extend(start / sequence.duration for start in starts)
        signals[signal_id] = SignalArrays(
            present=count > 0,
            count=count,
            start_min=extremes[0],
            start_max=extremes[1],
            stop_min=extremes[2],
            stop_max=extremes[3],
            lengths=np.array(lengths, dtype=np.float64),
            relative_starts=np.array(relative, dtype=np.float64),
        )
    return CorpusArrays(durations, signals)
