"""The exact CP-SAT backend (OR-Tools, imported only inside functions): docs/solvers.md (the backend: solver.py)."""
