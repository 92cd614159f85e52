"""Constraint trees read from Greta, simplified and printed in the native grammar.

Greta writes constraints as XML trees (``<con type=...><arg .../></con>``); the importer
turns each into the small tree below, then :func:`simplify` removes what the native
language cannot say (references to signals the behaviour set lacks, relations of a signal
with itself) and :func:`render` prints the result with the fewest parentheses the
precedence of the grammar (``not`` > ``and`` > ``or`` > ``implies``) needs.

Signals are already native ids (``s<N>``) here; times are seconds.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Truth = Literal["true", "false", "unknown"]
Edge = Literal["start", "stop"]


@dataclass(frozen=True, slots=True)
class GConst:
    """A truth value left by simplification (strong Kleene: true, false, unknown)."""

    value: Truth


@dataclass(frozen=True, slots=True)
class GExists:
    signal: str


@dataclass(frozen=True, slots=True)
class GRelation:
    kind: Literal["includes", "excludes", "precedes", "rightincludes"]
    left: str
    right: str


@dataclass(frozen=True, slots=True)
class GTime:
    signal: str
    edge: Edge


@dataclass(frozen=True, slots=True)
class GCompare:
    op: Literal["<", ">", "="]
    left: GTime
    right: GTime
    tolerance: float = 0.0


@dataclass(frozen=True, slots=True)
class GNot:
    operand: GExpr


@dataclass(frozen=True, slots=True)
class GAnd:
    operands: tuple[GExpr, ...]


@dataclass(frozen=True, slots=True)
class GOr:
    operands: tuple[GExpr, ...]


@dataclass(frozen=True, slots=True)
class GImplies:
    left: GExpr
    right: GExpr


GExpr = GConst | GExists | GRelation | GCompare | GNot | GAnd | GOr | GImplies

TRUE = GConst("true")
FALSE = GConst("false")
UNKNOWN = GConst("unknown")


def signals_of(expr: GExpr) -> frozenset[str]:
    """Every signal named in ``expr``."""
    if isinstance(expr, GExists):
        return frozenset({expr.signal})
    if isinstance(expr, GRelation):
        return frozenset({expr.left, expr.right})
    if isinstance(expr, GCompare):
        return frozenset({expr.left.signal, expr.right.signal})
    return frozenset().union(*(signals_of(child) for child in _children(expr)))


def triggers_of(expr: GExpr) -> frozenset[str]:
    """Signals named in relational atoms (the instantiation rule of the semantics)."""
    if isinstance(expr, GRelation | GCompare):
        return signals_of(expr)
    return frozenset().union(*(triggers_of(child) for child in _children(expr)))


def has_constant(expr: GExpr) -> bool:
    if isinstance(expr, GConst):
        return True
    return any(has_constant(child) for child in _children(expr))


def _children(expr: GExpr) -> tuple[GExpr, ...]:
    if isinstance(expr, GNot):
        return (expr.operand,)
    if isinstance(expr, GAnd | GOr):
        return expr.operands
    if isinstance(expr, GImplies):
        return (expr.left, expr.right)
    return ()


# -- simplification -----------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Rewrite:
    """What :func:`simplify` changed, for the W502 message."""

    missing: frozenset[str]
    self_relations: tuple[GRelation, ...]


def simplify(expr: GExpr, known: frozenset[str]) -> tuple[GExpr, Rewrite]:
    """Replace atoms the native language cannot state, then fold constants (Kleene).

    - An atom naming a signal outside ``known``: that signal never occurs, so
      ``exists`` is false and a relational atom is unknown (never instantiated).
    - A relation of a signal with itself: Greta uses ``rightinc(a, a)`` as "a occurs"
      (regret); for one occurrence ``includes``/``rightincludes`` hold and
      ``precedes``/``excludes`` fail, so they become ``exists(a)`` / ``not exists(a)``.
    """
    missing: set[str] = set()
    selfs: list[GRelation] = []

    def visit(node: GExpr) -> GExpr:
        if isinstance(node, GExists):
            if node.signal not in known:
                missing.add(node.signal)
                return FALSE
            return node
        if isinstance(node, GRelation | GCompare):
            absent = signals_of(node) - known
            if absent:
                missing.update(absent)
                return UNKNOWN
            if isinstance(node, GRelation) and node.left == node.right:
                selfs.append(node)
                holds = node.kind in ("includes", "rightincludes")
                return GExists(node.left) if holds else GNot(GExists(node.left))
            return node
        if isinstance(node, GNot):
            return _not(visit(node.operand))
        if isinstance(node, GAnd):
            return _and(tuple(visit(op) for op in node.operands))
        if isinstance(node, GOr):
            return _or(tuple(visit(op) for op in node.operands))
        if isinstance(node, GImplies):
            left, right = visit(node.left), visit(node.right)
            if isinstance(left, GConst) or isinstance(right, GConst):
                return _or((_not(left), right))
            return GImplies(left, right)
        return node

    return visit(expr), Rewrite(frozenset(missing), tuple(selfs))


def _not(operand: GExpr) -> GExpr:
    if isinstance(operand, GConst):
        flipped: dict[Truth, Truth] = {"true": "false", "false": "true", "unknown": "unknown"}
        return GConst(flipped[operand.value])
    return GNot(operand)


def _and(operands: tuple[GExpr, ...]) -> GExpr:
    kept = [op for op in operands if op != TRUE]
    if FALSE in kept:
        return FALSE
    if not kept:
        return TRUE
    if all(op == UNKNOWN for op in kept):
        return UNKNOWN
    return kept[0] if len(kept) == 1 else GAnd(tuple(kept))


def _or(operands: tuple[GExpr, ...]) -> GExpr:
    kept = [op for op in operands if op != FALSE]
    if TRUE in kept:
        return TRUE
    if not kept:
        return FALSE
    if all(op == UNKNOWN for op in kept):
        return UNKNOWN
    return kept[0] if len(kept) == 1 else GOr(tuple(kept))


# -- printing -----------------------------------------------------------------------------
_IMPLIES, _OR, _AND, _NOT, _ATOM = range(5)


def render(expr: GExpr) -> str:
    """Native constraint text (plain: the XML writer escapes ``<`` and ``>``)."""
    return _render(expr, _IMPLIES)


def _number(value: float) -> str:
    text = f"{value:.3f}".rstrip("0").rstrip(".")
    return text or "0"


def _time(term: GTime) -> str:
    return f"{term.edge}({term.signal})"


def _render(expr: GExpr, context: int) -> str:
    level: int
    if isinstance(expr, GConst):
        raise ValueError("constants are removed before printing")
    if isinstance(expr, GExists):
        return f"exists({expr.signal})"
    if isinstance(expr, GRelation):
        return f"{expr.kind}({expr.left}, {expr.right})"
    if isinstance(expr, GCompare):
        if expr.op == "=":
            return f"equal({_time(expr.left)}, {_time(expr.right)}, {_number(expr.tolerance)})"
        return f"{_time(expr.left)} {expr.op} {_time(expr.right)}"
    if isinstance(expr, GNot):
        text, level = "not " + _render(expr.operand, _NOT), _NOT
    elif isinstance(expr, GAnd):
        text, level = " and ".join(_render(op, _AND + 1) for op in expr.operands), _AND
    elif isinstance(expr, GOr):
        text, level = " or ".join(_render(op, _OR + 1) for op in expr.operands), _OR
    else:  # implies is right-associative: parenthesise an implication on the left
        left = _render(expr.left, _IMPLIES + 1)
        text, level = f"{left} implies {_render(expr.right, _IMPLIES)}", _IMPLIES
    return f"({text})" if level < context else text


def flatten(expr: GExpr) -> GExpr:
    """Merge nested ``and``/``or`` (Greta's connectives are binary) for readable text."""
    if isinstance(expr, GNot):
        return GNot(flatten(expr.operand))
    if isinstance(expr, GImplies):
        return GImplies(flatten(expr.left), flatten(expr.right))
    if isinstance(expr, GAnd | GOr):
        kind = type(expr)
        merged: list[GExpr] = []
        for operand in (flatten(op) for op in expr.operands):
            merged.extend(operand.operands if isinstance(operand, kind) else (operand,))
        return kind(tuple(merged))
    return expr
