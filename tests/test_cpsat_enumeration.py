"""CP-SAT's grid enumeration against the csp oracle: cases hypothesis once found.

With presolve and probing on, CP-SAT 9.15's ``enumerate_all_solutions`` dropped schedules the
encoding admits (e.g. s2 twice back to back beside s1): ``enumerate_schedules`` now searches
without them.  Each case here is a model of tests/strategies.py that made
``test_csp.py::test_grid_enumerations_agree`` fail."""

from __future__ import annotations

import pytest

from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.schedule import Occurrence, Schedule
from mse.solve.cpsat.solver import enumerate_schedules
from mse.solve.csp.solver import enumerate_grid


def _signal(name: str, max_duration: float | None) -> ir.Signal:
    return ir.Signal(id=name, modality="face", lexeme=f"lex={name}", min_duration=0.1, max_duration=max_duration,
                     probability_start=0.0, probability_end=0.5, repetitivity=1, max_occurrences=None, motion=None)


def _model(*signals: ir.Signal, exclusive: bool = True) -> ir.Model:
    return ir.Model(name="generated", signals=signals, constraints=(),
                    modalities=(ir.Modality(name="face", exclusive=exclusive),), description="", path="<memory>")


# Three repetitive face signals in an exclusive modality, min 0.1 s, max 0.5/None/0.5 s.
THREE_FACES = _model(_signal("s1", 0.5), _signal("s2", None), _signal("s3", 0.5))
S2_TWICE = (
    Schedule(1500, (Occurrence(0, 500, "s1"), Occurrence(500, 1000, "s2"), Occurrence(1000, 1500, "s2"))),
    Schedule(1500, (Occurrence(0, 500, "s2"), Occurrence(500, 1000, "s1"), Occurrence(1000, 1500, "s2"))),
)


@pytest.mark.parametrize("model", [
    THREE_FACES,
    _model(_signal("s1", 0.5), _signal("s2", None)),
    _model(_signal("s1", None), _signal("s2", None), _signal("s3", 0.5)),
    _model(_signal("s1", 0.5), _signal("s2", None), _signal("s3", 0.5), exclusive=False),
], ids=["three-faces", "two-faces", "two-open-faces", "three-faces-shared"])
def test_enumerations_agree(model: ir.Model) -> None:
    by_csp = enumerate_grid(model, 1.5, 0.5, limit=5000)
    by_cpsat = enumerate_schedules(model, 1.5, 0.5, limit=5000)
    assert len(by_csp) < 5000
    assert set(by_cpsat) == set(by_csp)
    assert len(by_cpsat) == len(set(by_cpsat))
    assert all(check_schedule(model, schedule) == [] for schedule in by_cpsat)


def test_a_signal_twice_back_to_back_is_enumerated() -> None:
    found = set(enumerate_schedules(THREE_FACES, 1.5, 0.5))
    for schedule in S2_TWICE:
        assert check_schedule(THREE_FACES, schedule) == []
        assert schedule in found
