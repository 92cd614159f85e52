"""Resolved, typed model of an MSE expression and the one semantic evaluator."""
