"""The positioned AST: what the file says, before names are resolved.

Numbers are still seconds as written; :mod:`mse.ir.build` validates and resolves them.
Every node carries the span of its first token in the host file.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mse.diagnostics import Span


@dataclass(frozen=True, slots=True)
class Name:
    text: str
    span: Span


@dataclass(frozen=True, slots=True)
class SignalTimeNode:
    signal: Name
    edge: str  # "start" | "stop"
    offset: float
    span: Span


@dataclass(frozen=True, slots=True)
class DurationNode:
    offset: float
    span: Span


@dataclass(frozen=True, slots=True)
class SpeechTimeNode:
    """``speech.start``, ``speech.stop``, ``stressed`` (= ``stressed.start``) or
    ``stressed.stop``, plus an offset: a time of the agent's speech."""

    anchor: str  # "start" | "stop" | "stressed_start" | "stressed_stop"
    offset: float
    span: Span


@dataclass(frozen=True, slots=True)
class NumberNode:
    value: float
    span: Span


@dataclass(frozen=True, slots=True)
class DifferenceNode:
    """``stop(a) - start(b) + offset``; ``length(a)`` is ``stop(a) - start(a)``."""

    minuend: SignalTimeNode
    subtrahend: SignalTimeNode
    offset: float
    span: Span


TermNode = SignalTimeNode | DifferenceNode | DurationNode | SpeechTimeNode | NumberNode


@dataclass(frozen=True, slots=True)
class ExistsNode:
    signal: Name
    span: Span


@dataclass(frozen=True, slots=True)
class RelationNode:
    kind: str  # includes | excludes | precedes | rightincludes
    left: Name
    right: Name
    span: Span


@dataclass(frozen=True, slots=True)
class CompareNode:
    """``left op right``; ``lessthan``/``morethan``/``equal`` map to ``<``/``>``/``=``."""

    op: str
    left: TermNode
    right: TermNode
    tolerance: NumberNode | None
    span: Span


@dataclass(frozen=True, slots=True)
class NotNode:
    operand: ExprNode
    span: Span


@dataclass(frozen=True, slots=True)
class BinaryNode:
    """``and`` / ``or`` / ``implies``."""

    op: str
    left: ExprNode
    right: ExprNode
    span: Span


ExprNode = ExistsNode | RelationNode | CompareNode | NotNode | BinaryNode


@dataclass(frozen=True, slots=True)
class Attribute:
    """An XML attribute value with the span of the attribute in the file."""

    value: str
    span: Span


@dataclass(frozen=True, slots=True)
class MotionDecl:
    attributes: dict[str, Attribute]
    span: Span


@dataclass(frozen=True, slots=True)
class SignalDecl:
    attributes: dict[str, Attribute]
    motion: MotionDecl | None
    span: Span


@dataclass(frozen=True, slots=True)
class ModalityDecl:
    name: Attribute
    exclusive: Attribute | None
    span: Span


@dataclass(frozen=True, slots=True)
class ConstraintDecl:
    id: Attribute | None
    text: str
    expr: ExprNode | None  # None when the text did not parse (the error is reported)
    span: Span


@dataclass(frozen=True, slots=True)
class Document:
    """One behaviour-set file."""

    path: str
    name: Attribute | None
    description: str
    modalities: tuple[ModalityDecl, ...]
    signals: tuple[SignalDecl, ...]
    constraints: tuple[ConstraintDecl, ...]
    span: Span
    has_signals_element: bool = True
    extra: dict[str, str] = field(default_factory=dict)
