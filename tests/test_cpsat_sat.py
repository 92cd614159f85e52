"""mse.solve.cpsat.sat, the pandas-free slice of OR-Tools' cp_model: the same protos, the same
answers, and a proof from the command line that never imports pandas."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from strategies import models

from mse import api
from mse.ir import model as ir
from mse.ir.schedule import to_ticks
from mse.resources import bundled_names
from mse.solve.bounds import slot_counts
from mse.solve.cpsat import sat
from mse.solve.cpsat.encode import build
from mse.solve.cpsat.objective import set_objective
from mse.solve.cpsat.prior import frame_priors

FIXTURES = Path(__file__).parent / "fixtures"


def _reference_model_class() -> Any:
    from ortools.sat.python import cp_model

    class Reference(cp_model.CpModel):  # type: ignore[misc]
        def _add_pre_pep8_methods(self) -> None:
            pass

    return Reference


def _both(monkeypatch: pytest.MonkeyPatch, make: Any) -> tuple[Any, Any]:
    """What ``make()`` builds with this module's CpModel and with cp_model's own."""
    light = make()
    with monkeypatch.context() as patch:
        patch.setattr(sat, "CpModel", _reference_model_class())
        reference = make()
    return light, reference


def _sampling_encoding(model: ir.Model, seed: int) -> Any:
    import random

    ticks = to_ticks(10.0)
    priors = frame_priors(model, ticks, 0, ticks, {}, {}, random.Random(seed), mode="sample")
    enc = build(model, ticks, {name: len(slots) for name, slots in priors.items()})
    set_objective(enc, None, seed, priors, (), ())
    enc.cp.add_hint(enc.slots[model.signals[0].id][0].present, False)
    return enc


@pytest.mark.skipif(not sat.LIGHT, reason="this OR-Tools has no pandas-free entry points (cp_model is used)")
@pytest.mark.parametrize("name", bundled_names())
def test_the_same_protos_as_cp_model(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    model = api.load(name)
    ticks = to_ticks(10.0)
    counts = slot_counts(model, ticks, complete=True)
    for make in (lambda: build(model, ticks, counts, switchable=True),
                 lambda: build(model, ticks, counts, constraints=False, violate=True),
                 lambda: _sampling_encoding(model, 3)):
        light, reference = _both(monkeypatch, make)
        assert type(light.cp) is sat.CpModel
        assert str(light.cp.proto) == str(reference.cp.proto)


@pytest.mark.skipif(not sat.LIGHT, reason="this OR-Tools has no pandas-free entry points (cp_model is used)")
@settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck))
@given(model=models(min_signals=1, max_signals=6, max_constraints=6))
def test_the_same_answers_as_cp_model(model: ir.Model) -> None:
    from ortools.sat.python import cp_model

    ticks = to_ticks(6.0)
    enc = build(model, ticks, slot_counts(model, ticks, complete=True), switchable=True)
    enc.cp.add_assumptions(list(enc.enable.values()))
    answers = []
    for solver in (sat.CpSolver(), cp_model.CpSolver()):
        solver.parameters.num_workers = 1
        solver.parameters.max_deterministic_time = 5.0
        status = solver.solve(enc.cp)
        values = [solver.value(slot.start) for slots in enc.slots.values() for slot in slots
                  if status in (sat.OPTIMAL, sat.FEASIBLE)]
        core = list(solver.sufficient_assumptions_for_infeasibility()) if status == sat.INFEASIBLE else []
        answers.append((int(status), values, core))
    assert answers[0] == answers[1]


def test_a_proof_from_the_command_line_does_not_import_pandas(tmp_path: Path) -> None:
    code = ("import sys\nfrom mse.cli import main\n"
            f"code = main(['sample', {str(FIXTURES / 'solvers' / 'conflict.xml')!r}, '--duration', '2'])\n"
            "print(code, 'pandas' in sys.modules, 'ortools.sat.python.cp_model' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False,
                          cwd=tmp_path)
    assert done.stdout.split() == ["2", "False", str(not sat.LIGHT)], done.stderr
    assert "no timeline of 2 s" in done.stderr
