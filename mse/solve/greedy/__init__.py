"""The greedy stochastic sampler of the paper (§4.3): docs/sampler.md."""

from mse.solve.greedy.solver import GreedySolver

__all__ = ["GreedySolver"]
