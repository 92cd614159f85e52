"""mse: compiler and solvers for multimodal sequential expressions (MSE) of emotion.

Four parts, data flowing one way:
- ``mse.syntax``: XML and constraint text -> positioned AST (lark grammar, lxml);
- ``mse.ir``: the resolved, typed model and the one semantic evaluator (``ir.evaluate``);
- ``mse.solve``: backends behind one protocol (greedy sampler, CP-SAT, python-constraint);
- ``mse.timeline`` -> ``mse.export`` (JSON, BML, SVG, HTML) and ``mse.motion`` (motion leaves).

The public API (docs/api.md): ``load``, ``loads``, ``sample``, ``iter_timelines``,
``iter_sample``, ``check``, ``lint``, ``explain``, ``repair`` and the types they take and return
(``Model``, ``Timeline``, ``TimelineSignal``, ``Pin``, ``SolveRequest``, ``GreedyOptions``,
``CpSatOptions``, ``CspOptions``, ``SolveResult``, ``Solution``, ``Status``, ``Violation``,
``Explanation``, ``Diagnostic``, ``MseError``, ``NoSolution``, ``Repair``, ``NoRepair``),
imported on first use.

>>> import mse
>>> model = mse.load("anger")
>>> timeline = mse.sample(model, 10.0, seed=3, solver="cpsat", pinned=[mse.Pin("frown", 1.0, 2.5)])
>>> mse.check(model, timeline)
[]
"""

from __future__ import annotations

__version__ = "0.1.0"

# No import at run time: a Ctrl-C while the package loads can then only come before the
# command line's own handler (mse/__main__.py), never as a traceback from inside an import.
TYPE_CHECKING = False
if TYPE_CHECKING:
    from typing import Any

    from mse.api import check, lint, load, loads, repair
    from mse.diagnostics import Diagnostic, MseError
    from mse.ir.evaluate import Violation
    from mse.ir.model import Model
    from mse.repairing.repair import NoRepair, Repair
    from mse.sampling import explain, iter_sample, iter_timelines, sample
    from mse.solve.cpsat.explain import Explanation
    from mse.solve.protocol import (
        CpSatOptions,
        CspOptions,
        GreedyOptions,
        NoSolution,
        Pin,
        Solution,
        SolveRequest,
        SolveResult,
        Status,
    )
    from mse.timeline import Timeline, TimelineSignal

# The public names are imported on first use, so that `import mse` (and the command
# line's start) stays cheap.
_LAZY = {
    "check": "mse.api",
    "explain": "mse.sampling",
    "iter_sample": "mse.sampling",
    "iter_timelines": "mse.sampling",
    "lint": "mse.api",
    "load": "mse.api",
    "loads": "mse.api",
    "sample": "mse.sampling",
    "repair": "mse.api",
    "Diagnostic": "mse.diagnostics",
    "MseError": "mse.diagnostics",
    "Violation": "mse.ir.evaluate",
    "Model": "mse.ir.model",
    "Timeline": "mse.timeline",
    "TimelineSignal": "mse.timeline",
    "Repair": "mse.repairing.repair",
    "NoRepair": "mse.repairing.repair",
    "Pin": "mse.solve.protocol",
    "SolveRequest": "mse.solve.protocol",
    "NoSolution": "mse.solve.protocol",
    "GreedyOptions": "mse.solve.protocol",
    "CpSatOptions": "mse.solve.protocol",
    "CspOptions": "mse.solve.protocol",
    "SolveResult": "mse.solve.protocol",
    "Solution": "mse.solve.protocol",
    "Status": "mse.solve.protocol",
    "Explanation": "mse.solve.cpsat.explain",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'mse' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


__all__ = [
    "CpSatOptions",
    "CspOptions",
    "Diagnostic",
    "Explanation",
    "GreedyOptions",
    "Model",
    "MseError",
    "NoRepair",
    "NoSolution",
    "Pin",
    "Repair",
    "Solution",
    "SolveRequest",
    "SolveResult",
    "Status",
    "Timeline",
    "TimelineSignal",
    "Violation",
    "__version__",
    "check",
    "explain",
    "iter_sample",
    "iter_timelines",
    "lint",
    "load",
    "loads",
    "repair",
    "sample",
]
