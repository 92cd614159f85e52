"""The compiled IR as JSON (``mse compile``) and back (``mse compile x.xml | mse sample``).

Reading the JSON back goes through the same checks as a file: the constraint ``text``
is re-parsed and re-resolved, and every entry keeps its ``source`` position so that later
diagnostics still point into the original XML file.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from mse.diagnostics import Diagnostic, MseError, Span
from mse.ir import model as ir
from mse.ir.build import build_model
from mse.ir.decode import parse_source
from mse.ir.printer import expr_text, seconds
from mse.limits import MAX_CONSTRAINT_CHARS, MAX_CONSTRAINT_TEXT
from mse.syntax import ast
from mse.syntax.expression import parse_expression

FORMAT = "mse-ir/1"


def _source(span: Span) -> str:
    text: str = span.render()
    return text


def _term_json(term: ir.Term) -> dict[str, Any]:
    if isinstance(term, ir.SignalTime):
        return {term.edge: term.signal, "offset": term.offset / 1000}
    if isinstance(term, ir.DurationTime):
        return {"duration": True, "offset": term.offset / 1000}
    if isinstance(term, ir.SpeechTime):
        return {"speech": term.anchor, "offset": term.offset / 1000}
    return {"value": term.value / 1000}


def expr_json(expr: ir.Expr) -> dict[str, Any]:
    if isinstance(expr, ir.Exists):
        return {"op": "exists", "signal": expr.signal}
    if isinstance(expr, ir.Relation):
        return {"op": expr.kind, "left": expr.left, "right": expr.right}
    if isinstance(expr, ir.Compare):
        node: dict[str, Any] = {"op": expr.op, "left": _term_json(expr.left), "right": _term_json(expr.right)}
        if expr.tolerance:
            node["tolerance"] = expr.tolerance / 1000
        return node
    if isinstance(expr, ir.Not):
        return {"op": "not", "args": [expr_json(expr.operand)]}
    if isinstance(expr, ir.Implies):
        return {"op": "implies", "args": [expr_json(expr.left), expr_json(expr.right)]}
    return {"op": "and" if isinstance(expr, ir.And) else "or", "args": [expr_json(e) for e in expr.operands]}


def _signal_json(signal: ir.Signal) -> dict[str, Any]:
    entry: dict[str, Any] = {
        "id": signal.id,
        "modality": signal.modality,
        "lexeme": signal.lexeme,
        "min_duration": signal.min_duration,
        "max_duration": signal.max_duration,
        "probability_start": signal.probability_start,
        "probability_end": signal.probability_end,
        "repetitivity": signal.repetitivity,
    }
    if signal.max_occurrences is not None:
        entry["max_occurrences"] = signal.max_occurrences
    if signal.intensity != 1.0:
        entry["intensity"] = signal.intensity
    if signal.motion is not None:
        entry["motion"] = {"action": signal.motion.action, **dict(signal.motion.attributes)}
    entry["source"] = _source(signal.span)
    return entry


def model_to_json(model: ir.Model) -> dict[str, Any]:
    return {
        "format": FORMAT,
        "name": model.name,
        "description": model.description,
        "path": model.path,
        "modalities": [{"name": m.name, "exclusive": m.exclusive} for m in model.modalities],
        "signals": [_signal_json(s) for s in model.signals],
        "constraints": [
            {
                "id": c.id,
                "text": expr_text(c.expr),
                "explicit_id": c.explicit_id,
                "triggers": sorted(c.triggers),
                "expr": expr_json(c.expr),
                "source": _source(c.span),
            }
            for c in model.constraints
        ],
    }


def model_dumps(model: ir.Model) -> str:
    return json.dumps(model_to_json(model), indent=2, ensure_ascii=False)


def _span(value: object, fallback: Span) -> Span:
    return parse_source(value) if isinstance(value, str) else fallback


def _attribute_text(value: object) -> str:
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def _fixed(span: Span) -> Callable[[int], Span]:
    def locate(offset: int) -> Span:
        return span

    return locate


def model_from_json(obj: Any, *, path: str = "<stdin>") -> ir.Model:
    """Rebuild a Model from ``mse compile`` output; raises MseError on malformed input."""
    where = Span(path)
    if not isinstance(obj, dict) or obj.get("format") != FORMAT:
        raise MseError([Diagnostic("E100", f'not compiled MSE IR (expected "format": "{FORMAT}")', where)])
    for key in ("signals", "constraints", "modalities"):
        if not isinstance(obj.get(key, []), list):
            raise MseError([Diagnostic("E100", f"'{key}' must be a list", where)])
    signals: list[ast.SignalDecl] = []
    for entry in obj.get("signals") or []:
        if not isinstance(entry, dict):
            raise MseError([Diagnostic("E100", "each signal must be an object", where)])
        span = _span(entry.get("source"), where)
        attributes = {
            key: ast.Attribute(_attribute_text(value), span)
            for key, value in entry.items()
            if key not in ("source", "motion") and value is not None
        }
        motion = entry.get("motion")
        motion_decl = (
            ast.MotionDecl({k: ast.Attribute(_attribute_text(v), span) for k, v in motion.items()}, span)
            if isinstance(motion, dict)
            else None
        )
        signals.append(ast.SignalDecl(attributes, motion_decl, span))
    constraints: list[ast.ConstraintDecl] = []
    diagnostics: list[Diagnostic] = []
    budget = MAX_CONSTRAINT_TEXT
    for entry in obj.get("constraints") or []:
        if not isinstance(entry, dict) or not isinstance(entry.get("text"), str):
            raise MseError([Diagnostic("E100", "each constraint must be an object with a 'text'", where)])
        span = _span(entry.get("source"), where)
        text = entry["text"]
        budget -= len(text)
        if len(text) > MAX_CONSTRAINT_CHARS or budget < 0:
            what = f"constraint is longer than {MAX_CONSTRAINT_CHARS}"
            if budget < 0:
                what = f"constraints are longer than {MAX_CONSTRAINT_TEXT} together"
            raise MseError([Diagnostic("E104", f"{what} characters", span)])
        expr, problems = parse_expression(text, _fixed(span))
        diagnostics.extend(problems)
        explicit = entry.get("explicit_id", True)
        constraint_id = ast.Attribute(str(entry.get("id", "")), span) if explicit else None
        constraints.append(ast.ConstraintDecl(constraint_id, text, expr, span))
    modalities = tuple(
        ast.ModalityDecl(
            ast.Attribute(str(m.get("name", "")), where),
            ast.Attribute("true" if m.get("exclusive") else "false", where),
            where,
        )
        for m in obj.get("modalities") or []
        if isinstance(m, dict)
    )
    document = ast.Document(
        path=str(obj.get("path") or path),
        name=ast.Attribute(str(obj.get("name", "expression")), where),
        description=str(obj.get("description", "")),
        modalities=modalities,
        signals=tuple(signals),
        constraints=tuple(constraints),
        span=where,
    )
    model, problems = build_model(document)
    diagnostics.extend(problems)
    if model is None or diagnostics:
        raise MseError(diagnostics)
    return model


__all__ = ["FORMAT", "expr_json", "model_dumps", "model_from_json", "model_to_json", "seconds"]
