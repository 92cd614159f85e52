"""Structure-aware fuzzing (issue 13): real documents mutated at the token level, expressions
drawn from the grammar, timelines, BVH clips and compiled IR with hostile values.  Every case
runs under a wall-clock bound and a memory bound; the invariants live in ``fuzzing.py``:
no traceback, an E-code with a position, consistent timelines, well-formed exports.

``bench/robustness/fuzz.py`` runs the same targets much longer (and coverage-guided with atheris)."""

from __future__ import annotations

import os
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.fuzzing import STRATEGIES, TARGETS, bounded, peak_rss_kib

#: Wall-clock bound of one case.  The slowest case of a 20-minute run took 1.4 s, but CI
#: shares 2 cores with other jobs; the bugs this guards against took minutes.
CASE_SECONDS = 60.0
#: Growth of the worker's peak RSS over the whole fuzz run (the bugs took gigabytes).
RSS_GROWTH_KIB = 1_000_000
EXAMPLES = {"xml": 400, "expression": 400, "timeline": 300, "bvh": 150, "ir": 200, "learn": 60, "render": 40,
            "stdio": 12, "model": 30}
#: MSE_FUZZ_SCALE=10 runs ten times as many examples (locally; CI keeps the default).
SCALE = float(os.environ.get("MSE_FUZZ_SCALE", "1"))

_BASELINE: list[int] = []


def _run(name: str, case: Any, seed: int) -> None:
    if not _BASELINE:
        _BASELINE.append(peak_rss_kib())
    with bounded(CASE_SECONDS) as measure:
        TARGETS[name](case, seed)
    assert measure.peak_rss_kib - _BASELINE[0] < RSS_GROWTH_KIB, f"peak RSS grew to {measure.peak_rss_kib} KiB"


def _fuzz(name: str) -> Any:
    @settings(
        max_examples=max(1, int(EXAMPLES[name] * SCALE)),
        deadline=None,
        print_blob=True,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much],
    )
    @given(case=STRATEGIES[name], seed=st.integers(0, 2**31 - 1))
    def test(case: Any, seed: int) -> None:
        _run(name, case, seed)

    return test


@pytest.mark.slow
def test_fuzz_behaviour_set_documents() -> None:
    _fuzz("xml")()


@pytest.mark.slow
def test_fuzz_constraint_expressions() -> None:
    _fuzz("expression")()


@pytest.mark.slow
def test_fuzz_timelines() -> None:
    _fuzz("timeline")()


@pytest.mark.slow
def test_fuzz_bvh_clips() -> None:
    _fuzz("bvh")()


@pytest.mark.slow
def test_fuzz_compiled_ir() -> None:
    _fuzz("ir")()


@pytest.mark.slow
def test_fuzz_learn_inputs() -> None:
    _fuzz("learn")()


@pytest.mark.slow
def test_fuzz_render_inputs() -> None:
    _fuzz("render")()


@pytest.mark.slow
def test_fuzz_unwritable_stdout() -> None:
    _fuzz("stdio")()


@pytest.mark.slow
def test_fuzz_model_files() -> None:
    _fuzz("model")()
