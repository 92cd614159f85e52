"""The python-constraint grid search, used as an oracle in tests: docs/solvers.md (the backend: solver.py)."""
