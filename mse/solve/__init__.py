"""Solver backends behind one protocol: greedy (stochastic sampler), cpsat, csp."""
