"""The exact CP-SAT backend (OR-Tools, imported only inside functions): docs/solvers.md."""

from mse.solve.cpsat.solver import CpSatSolver

__all__ = ["CpSatSolver"]
