"""Learning behaviour sets and constraint sets from annotated recordings (docs/learn.md).

``learn(paths)`` reads ELAN files, CSV/TSV tables or mse timelines and returns the learned
set (XML text and model), the evidence of every rule and the corpus sequences that break
them.  Layer: beside ``mse.export`` and ``mse.motion`` (it may use syntax, ir, solve,
timeline and export).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from mse.learn.corpus import DEFAULT_MAPPING, Corpus, TierMapping
from mse.learn.learn import DEFAULT_OPTIONS, Break, LearnOptions, LearnResult, learn_corpus

__all__ = ["Break", "Corpus", "LearnOptions", "LearnResult", "TierMapping", "learn", "learn_corpus", "read_corpus"]


def read_corpus(paths: Iterable[str | Path], mapping: TierMapping = DEFAULT_MAPPING) -> Corpus:
    """The corpus of the files (MseError with every problem on bad input)."""
    from mse.learn.read import read_corpus as read

    corpus, _notes = read(paths, mapping)
    return corpus


def learn(paths: Iterable[str | Path], options: LearnOptions = DEFAULT_OPTIONS,
          mapping: TierMapping = DEFAULT_MAPPING) -> LearnResult:
    """Learn a behaviour set from annotation files; reading notes (W503) come with the result."""
    from dataclasses import replace

    from mse.learn.read import read_corpus as read

    corpus, notes = read(paths, mapping)
    result = learn_corpus(corpus, options)
    return replace(result, diagnostics=[*notes, *result.diagnostics])
