"""The part of OR-Tools' CP-SAT Python API that mse uses, without pandas.

``ortools.sat.python.cp_model`` imports pandas and numpy at module level (for its
``*_series`` methods and type aliases, which mse does not use): 0.75 s of CPU, 1.3-1.6 s of
wall time on a busy disk, which was most of the time of an infeasibility proof from the
command line (docs/sampler.md "Proofs").  Its ``CpModel`` and ``CpSolver`` are thin Python
layers over the C++ extension ``cp_model_helper`` (``CpBaseModel``, ``SolveWrapper``,
``ResponseHelper``), which loads in 0.05 s and needs neither.  This module is the same thin
layer for the methods mse calls, each a copy of what ``cp_model`` 9.15 does, so that the
models built here are the same protos (tests/test_cpsat_sat.py compares them with
``cp_model``'s for every bundled set) and CP-SAT returns the same answers.

With an OR-Tools whose helper lacks these entry points (before 9.12), the classes are
``cp_model``'s own: slower to import, the same results.

Import this module only inside functions (it loads OR-Tools).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ortools.sat.python.cp_model_helper import IntVar as Var

try:
    from ortools.sat.python import cp_model_helper as _cmh
except ImportError:  # pragma: no cover - an OR-Tools without the C++ helper
    _cmh = None  # type: ignore[assignment]

_MODEL_ENTRY_POINTS = ("_add_bool_argument_constraint", "_add_bounded_linear_expression",
                       "_add_linear_argument_constraint", "_add_no_overlap", "_new_interval_var",
                       "get_or_make_boolean_index", "is_boolean_value", "model_proto")
#: Whether the pandas-free layer below is in use (else ``cp_model``'s classes are).
LIGHT = (_cmh is not None and hasattr(_cmh, "CpBaseModel") and hasattr(_cmh, "SolveWrapper")
         and hasattr(_cmh, "ResponseHelper") and hasattr(_cmh, "SatParameters")
         and all(hasattr(_cmh.CpBaseModel, name) for name in _MODEL_ENTRY_POINTS))

if LIGHT:
    from ortools.util.python.sorted_interval_list import Domain

    cmh: Any = _cmh
    IntVar: Any = cmh.IntVar
    UNKNOWN: Any = cmh.CpSolverStatus.UNKNOWN
    FEASIBLE: Any = cmh.CpSolverStatus.FEASIBLE
    INFEASIBLE: Any = cmh.CpSolverStatus.INFEASIBLE
    OPTIMAL: Any = cmh.CpSolverStatus.OPTIMAL
    HINT_SEARCH: Any = cmh.SatParameters.SearchBranching.HINT_SEARCH

    class CpModel(cmh.CpBaseModel):  # type: ignore[misc]
        """``cp_model.CpModel``'s methods that mse uses, as cp_model 9.15 writes them
        (without its per-instance camelCase aliases, which cost 4 ms per model)."""

        def __init__(self) -> None:
            cmh.CpBaseModel.__init__(self, None)

        @property
        def proto(self) -> Any:
            return self.model_proto

        def new_int_var(self, lb: int, ub: int, name: str) -> Var:
            variable: Var = IntVar(self.model_proto).with_name(name).with_domain(Domain(lb, ub))
            return variable

        def new_bool_var(self, name: str) -> Var:
            return self.new_int_var(0, 1, name)

        def add(self, ct: Any) -> Any:
            if isinstance(ct, cmh.BoundedLinearExpression):
                return self._add_bounded_linear_expression(ct)
            if ct and self.is_boolean_value(ct):
                return self.add_bool_or([True])
            if not ct and self.is_boolean_value(ct):
                return self.add_bool_or([])  # false
            raise TypeError(f"not supported: CpModel.add({type(ct).__name__!r})")

        def add_implication(self, a: Any, b: Any) -> Any:
            return self.add_bool_and(b).only_enforce_if(a)

        def add_bool_or(self, *literals: Any) -> Any:
            return self._add_bool_argument_constraint(cmh.BoolArgumentConstraint.bool_or, *literals)

        def add_bool_and(self, *literals: Any) -> Any:
            return self._add_bool_argument_constraint(cmh.BoolArgumentConstraint.bool_and, *literals)

        def add_abs_equality(self, target: Any, expr: Any) -> Any:
            return self._add_linear_argument_constraint(cmh.LinearArgumentConstraint.max, target, [expr, -expr])

        def new_fixed_size_interval_var(self, start: Any, size: int, name: str) -> Any:
            return self._new_interval_var(name, start, size, start + size, [])

        def new_optional_interval_var(self, start: Any, size: Any, end: Any, is_present: Any, name: str) -> Any:
            return self._new_interval_var(name, start, size, end, [is_present])

        def new_optional_fixed_size_interval_var(self, start: Any, size: int, is_present: Any, name: str) -> Any:
            return self._new_interval_var(name, start, size, start + size, [is_present])

        def add_no_overlap(self, intervals: Iterable[Any]) -> Any:
            return self._add_no_overlap(intervals)

        def minimize(self, obj: Any) -> None:
            self._set_objective(obj, maximize=False)

        def maximize(self, obj: Any) -> None:
            self._set_objective(obj, maximize=True)

        def _set_objective(self, obj: Any, maximize: bool) -> None:
            proto = self.model_proto
            proto.clear_objective()
            proto.clear_floating_point_objective()
            if isinstance(obj, int):
                proto.objective.offset = int(obj)
                proto.objective.scaling_factor = 1.0
            elif isinstance(obj, cmh.LinearExpr):
                if not obj.is_integer():
                    floating = cmh.FlatFloatExpr(obj)
                    for variable in floating.vars:
                        proto.floating_point_objective.vars.append(variable.index)
                    proto.floating_point_objective.coeffs.extend(floating.coeffs)
                    proto.floating_point_objective.maximize = maximize
                    proto.floating_point_objective.offset = floating.offset
                    return
                flat = cmh.FlatIntExpr(obj)
                for variable in flat.vars:
                    proto.objective.vars.append(variable.index)
                if maximize:
                    proto.objective.scaling_factor = -1.0
                    proto.objective.offset = -flat.offset
                    for coefficient in flat.coeffs:
                        proto.objective.coeffs.append(-coefficient)
                else:
                    proto.objective.scaling_factor = 1.0
                    proto.objective.offset = flat.offset
                    proto.objective.coeffs.extend(flat.coeffs)
            else:
                raise TypeError(f"{type(obj).__name__!r} is not a valid objective")

        def add_hint(self, var: Any, value: Any) -> None:
            hint = self.model_proto.solution_hint
            if var.index >= 0:
                hint.vars.append(var.index)
                hint.values.append(int(value))
            else:
                hint.vars.append(-var.index - 1)
                hint.values.append(int(not value))

        def clear_hints(self) -> None:
            self.model_proto.clear_solution_hint()

        def add_assumptions(self, literals: Iterable[Any]) -> None:
            for literal in literals:
                self.model_proto.assumptions.append(self.get_or_make_boolean_index(literal))

        def clear_assumptions(self) -> None:
            self.model_proto.assumptions.clear()

    class CpSolver:
        """``cp_model.CpSolver``'s solve and read-out, as cp_model 9.15 writes them."""

        def __init__(self) -> None:
            self.parameters: Any = cmh.SatParameters()
            self._response: Any = None

        def solve(self, model: CpModel, solution_callback: Any = None) -> Any:
            wrapper = cmh.SolveWrapper()
            wrapper.set_parameters(self.parameters)
            if solution_callback is not None:
                wrapper.add_solution_callback(solution_callback)
            self._response = wrapper.solve(model.proto)
            if solution_callback is not None:
                wrapper.clear_solution_callback(solution_callback)
            return self._response.status

        @property
        def response_proto(self) -> Any:
            return self._checked()

        def value(self, expression: Any) -> int:
            return int(cmh.ResponseHelper.value(self._checked(), expression))

        def boolean_value(self, literal: Any) -> bool:
            return bool(cmh.ResponseHelper.boolean_value(self._checked(), literal))

        def sufficient_assumptions_for_infeasibility(self) -> list[int]:
            return list(cmh.ResponseHelper.sufficient_assumptions_for_infeasibility(self._checked()))

        def _checked(self) -> Any:
            if self._response is None:
                raise RuntimeError("solve() has not been called.")
            return self._response

else:  # pragma: no cover - older OR-Tools: cp_model's own classes
    from ortools.sat.python import cp_model as _cp_model

    IntVar = _cp_model.IntVar
    UNKNOWN = _cp_model.UNKNOWN
    FEASIBLE = _cp_model.FEASIBLE
    INFEASIBLE = _cp_model.INFEASIBLE
    OPTIMAL = _cp_model.OPTIMAL
    HINT_SEARCH = _cp_model.HINT_SEARCH
    CpModel = _cp_model.CpModel  # type: ignore[misc,assignment]
    CpSolver = _cp_model.CpSolver  # type: ignore[misc,assignment]
