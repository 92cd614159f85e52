"""The greedy stochastic sampler of the paper (§4.3): docs/sampler.md (the backend: solver.py)."""
