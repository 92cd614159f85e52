"""mse: compiler and solvers for multimodal sequential expressions (MSE) of emotion.

Four parts, data flowing one way:
- ``mse.syntax``: XML and constraint text -> positioned AST (lark grammar, lxml);
- ``mse.ir``: the resolved, typed model and the one semantic evaluator (``ir.evaluate``);
- ``mse.solve``: backends behind one protocol (greedy sampler, CP-SAT, python-constraint);
- ``mse.timeline`` -> ``mse.export`` (JSON, BML, SVG, HTML) and ``mse.motion`` (motion leaves).
"""

from __future__ import annotations

__version__ = "0.1.0"

from mse.api import check, explain, iter_sample, lint, load, loads, sample
from mse.diagnostics import Diagnostic, MseError
from mse.ir.evaluate import Violation
from mse.ir.model import Model
from mse.timeline import Timeline

__all__ = [
    "Diagnostic",
    "Model",
    "MseError",
    "Timeline",
    "Violation",
    "__version__",
    "check",
    "explain",
    "iter_sample",
    "lint",
    "load",
    "loads",
    "sample",
]
