"""The python-constraint grid search, used as an oracle in tests: docs/solvers.md."""

from mse.solve.csp.solver import CspSolver

__all__ = ["CspSolver"]
