"""Rebuild a Model from JSON that mse wrote itself (the compiled-model cache).

Unlike :func:`mse.ir.canonical.model_from_json`, which re-parses and re-checks untrusted
input, this decodes the ``expr`` trees directly: no grammar, no XML, so a cached model
loads without importing lark or lxml.  Source spans are kept per signal and constraint.
"""

from __future__ import annotations

from typing import Any

from mse.diagnostics import Span
from mse.ir import model as ir
from mse.ir.relations import COMPARISONS, RELATIONS
from mse.ir.schedule import to_ticks


class DecodeError(ValueError):
    """The JSON is not a model mse wrote (a stale or damaged cache entry)."""


def parse_source(value: str) -> Span:
    """``path:line:col`` (as :meth:`Span.render` writes it) back to a Span; anything else
    is a path.  Split from the right, without a regular expression (linear on any input)."""
    path, _, rest = value.rpartition(":")
    path2, _, line = path.rpartition(":")
    if path2 and _is_count(line) and _is_count(rest):
        return Span(path2, int(line), int(rest))
    return Span(value)


def _is_count(text: str) -> bool:
    return 0 < len(text) <= 9 and text.isascii() and text.isdigit()


def _span(value: Any) -> Span:
    return parse_source(value) if isinstance(value, str) else Span(str(value))


def _term(node: dict[str, Any]) -> ir.Term:
    for edge in ("start", "stop"):
        if edge in node:
            return ir.SignalTime(str(node[edge]), edge, to_ticks(float(node.get("offset", 0))))
    if node.get("duration"):
        return ir.DurationTime(to_ticks(float(node.get("offset", 0))))
    if node.get("speech") in ("start", "stop", "stressed_start", "stressed_stop"):
        return ir.SpeechTime(node["speech"], to_ticks(float(node.get("offset", 0))))
    if "value" in node:
        return ir.Constant(to_ticks(float(node["value"])))
    raise DecodeError(f"not a term: {node!r}")




def decode_expr(node: dict[str, Any], span: Span) -> ir.Expr:
    op = node.get("op")
    if op == "exists":
        return ir.Exists(str(node["signal"]), span)
    if op in RELATIONS:
        return ir.Relation(op, str(node["left"]), str(node["right"]), span)
    if op in COMPARISONS:
        tolerance = to_ticks(float(node.get("tolerance", 0)))
        return ir.Compare(op, _term(node["left"]), _term(node["right"]), tolerance, span)
    args = [decode_expr(child, span) for child in node.get("args", [])]
    if op == "not" and len(args) == 1:
        return ir.Not(args[0], span)
    if op == "implies" and len(args) == 2:
        return ir.Implies(args[0], args[1], span)
    if op == "and" and args:
        return ir.And(tuple(args), span)
    if op == "or" and args:
        return ir.Or(tuple(args), span)
    raise DecodeError(f"not an expression: {op!r}")


def _motion(entry: Any, span: Span) -> ir.MotionLeaf | None:
    if not isinstance(entry, dict):
        return None
    attributes = {str(k): str(v) for k, v in entry.items()}
    return ir.MotionLeaf(
        action=attributes["action"],
        clip=attributes.get("clip"),
        nd=int(attributes.get("nd", 0)),
        states=int(attributes.get("states", 12)),
        method=attributes.get("method", "lma-hmm"),
        attributes=attributes,
        span=span,
    )


def model_from_trusted_json(obj: Any) -> ir.Model:
    """Decode :func:`mse.ir.canonical.model_to_json` output; DecodeError if malformed."""
    try:
        signals = []
        for entry in obj["signals"]:
            span = _span(entry.get("source"))
            maximum = entry.get("max_duration")
            signals.append(
                ir.Signal(
                    id=entry["id"],
                    modality=entry["modality"],
                    lexeme=entry["lexeme"],
                    min_duration=float(entry["min_duration"]),
                    max_duration=None if maximum is None else float(maximum),
                    probability_start=float(entry["probability_start"]),
                    probability_end=float(entry["probability_end"]),
                    repetitivity=int(entry["repetitivity"]),
                    max_occurrences=entry.get("max_occurrences"),
                    motion=_motion(entry.get("motion"), span),
                    span=span,
                    intensity=float(entry.get("intensity", 1.0)),
                )
            )
        constraints = []
        for entry in obj["constraints"]:
            span = _span(entry.get("source"))
            constraints.append(
                ir.Constraint(
                    id=entry["id"],
                    expr=decode_expr(entry["expr"], span),
                    explicit_id=bool(entry.get("explicit_id", True)),
                    text=entry.get("text", ""),
                    span=span,
                )
            )
        modalities = tuple(ir.Modality(m["name"], bool(m["exclusive"])) for m in obj["modalities"])
        return ir.Model(
            name=obj["name"],
            signals=tuple(signals),
            constraints=tuple(constraints),
            modalities=modalities,
            description=obj.get("description", ""),
            path=obj.get("path", "<cache>"),
        )
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise DecodeError(str(error)) from None
