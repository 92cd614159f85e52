"""Constraint expression text -> positioned AST, with the lark grammar as package data.

Positions: lark reports offsets inside the expression text; the caller passes ``locate``,
which turns an offset into the :class:`Span` of that character in the host file (the XML
file, with entities and CDATA accounted for).  Nothing outside this module sees lark.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from typing import Any

from lark import Lark, Token, Tree
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from mse.diagnostics import Diagnostic, Span
from mse.resources import grammar_dir
from mse.syntax import ast

#: Deeper expressions are refused (E111) instead of exhausting Python's stack.
MAX_DEPTH = 200

Locate = Callable[[int], Span]

_TOKEN_LABELS = {
    "LPAR": "'('",
    "RPAR": "')'",
    "COMMA": "','",
    "SIG": "a signal name",
    "NUMBER": "a number",
    "MINUS": "'-'",
    "PLUS": "'+'",
    "EDGE": "start(...) or stop(...)",
    "DURATION": "'duration'",
    "EXISTS": "'exists'",
    "RELATION": "includes/excludes/precedes/rightincludes",
    "ORDER": "lessthan/morethan",
    "EQUAL": "'equal'",
    "NOT": "'not'",
    "AND": "'and'",
    "OR": "'or'",
    "IMPLIES": "'implies'",
    "COMPARATOR": "a comparison (<, >, =, <=, >=)",
    "$END": "end of expression",
}


@functools.cache
def _parser() -> Lark:
    grammar = (grammar_dir() / "constraints.lark").read_text(encoding="utf-8")
    return Lark(grammar, parser="lalr", propagate_positions=True, maybe_placeholders=True)


def _describe_expected(expected: set[str]) -> str:
    labels = sorted({_TOKEN_LABELS.get(name, name) for name in expected})
    return ", ".join(labels)


def _syntax_error(error: UnexpectedInput, text: str, locate: Locate) -> Diagnostic:
    if isinstance(error, UnexpectedToken):
        token = error.token
        position = token.start_pos if token.start_pos is not None else len(text)
        found = "end of expression" if token.type == "$END" else repr(str(token))
        expected = _describe_expected(set(error.accepts or error.expected))
        message = f"unexpected {found} in constraint; expected {expected}"
    elif isinstance(error, UnexpectedCharacters):
        position = error.pos_in_stream or 0
        message = f"unexpected character {text[position]!r} in constraint"
        if text[position] in "&<>":
            message += " (write < as &lt; and > as &gt; in XML, or use CDATA)"
    elif isinstance(error, UnexpectedEOF):
        position = len(text)
        message = f"constraint ends too early; expected {_describe_expected(set(error.expected))}"
    else:  # pragma: no cover - lark has no other UnexpectedInput kinds
        position, message = 0, str(error)
    return Diagnostic("E110", message, locate(min(position, max(len(text) - 1, 0))))


def _depth(tree: Tree[Token]) -> int:
    """Nesting depth of a parse tree, computed without recursion."""
    deepest = 0
    stack: list[tuple[Tree[Token], int]] = [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        stack.extend((child, depth + 1) for child in node.children if isinstance(child, Tree))
    return deepest


def parse_expression(text: str, locate: Locate) -> tuple[ast.ExprNode | None, list[Diagnostic]]:
    """Parse one constraint's text; on error return None and the diagnostics."""
    if not text.strip():
        return None, [Diagnostic("E110", "empty constraint", locate(0))]
    try:
        tree = _parser().parse(text)
    except UnexpectedInput as error:
        return None, [_syntax_error(error, text, locate)]
    if _depth(tree) > MAX_DEPTH:
        return None, [Diagnostic("E111", f"constraint nested more than {MAX_DEPTH} levels deep", locate(0))]
    builder = _Builder(locate)
    expr = builder.expr(tree.children[0])
    return (None if builder.diagnostics else expr), builder.diagnostics


class _Builder:
    """Turns lark's tree into AST nodes (a hand-written walk keeps types precise)."""

    def __init__(self, locate: Locate) -> None:
        self.locate = locate
        self.diagnostics: list[Diagnostic] = []

    def span(self, item: Any) -> Span:
        if isinstance(item, Token):
            return self.locate(item.start_pos or 0)
        meta = item.meta
        return self.locate(meta.start_pos if not meta.empty else 0)

    def name(self, token: Token) -> ast.Name:
        return ast.Name(str(token), self.span(token))

    def number(self, token: Token, negative: bool = False) -> float:
        value = float(str(token))
        if not math.isfinite(value):
            self.diagnostics.append(Diagnostic("E112", f"number {token!s} is not finite", self.span(token)))
            return 0.0
        return -value if negative else value

    def expr(self, node: Tree[Token] | Token) -> ast.ExprNode:
        assert isinstance(node, Tree)
        kind = str(node.data)
        kids = node.children
        span = self.span(node)
        if kind in ("and_", "or_", "implies"):
            op = {"and_": "and", "or_": "or", "implies": "implies"}[kind]
            return ast.BinaryNode(op, self.expr(kids[0]), self.expr(kids[2]), span)
        if kind == "not_":
            return ast.NotNode(self.expr(kids[1]), span)
        if kind == "exists":
            return ast.ExistsNode(self.name(_token(kids[1])), span)
        if kind == "relation":
            head = _token(kids[0])
            return ast.RelationNode(str(head), self.name(_token(kids[1])), self.name(_token(kids[2])), span)
        if kind == "order":
            op = "<" if str(_token(kids[0])) == "lessthan" else ">"
            return ast.CompareNode(op, self.term(kids[1]), self.term(kids[2]), None, span)
        if kind == "equal":
            tolerance = None
            if kids[3] is not None:
                tol_token = _token(kids[3])
                tolerance = ast.NumberNode(self.number(tol_token), self.span(tol_token))
            return ast.CompareNode("=", self.term(kids[1]), self.term(kids[2]), tolerance, span)
        if kind == "compare":
            return ast.CompareNode(str(_token(kids[1])), self.term(kids[0]), self.term(kids[2]), None, span)
        raise AssertionError(f"unexpected parse node {kind}")  # pragma: no cover

    def offsets(self, nodes: Sequence[Tree[Token] | Token | None]) -> float:
        total = 0.0
        for offset in nodes:
            assert isinstance(offset, Tree)
            sign, value = _token(offset.children[0]), _token(offset.children[1])
            total += self.number(value, negative=str(sign) == "-")
        return total

    def term(self, node: Tree[Token] | Token | None) -> ast.TermNode:
        assert isinstance(node, Tree)
        kind = str(node.data)
        kids = node.children
        span = self.span(node)
        if kind == "signal_time":
            return ast.SignalTimeNode(self.name(_token(kids[1])), str(_token(kids[0])), self.offsets(kids[2:]), span)
        if kind == "duration_time":
            return ast.DurationNode(self.offsets(kids[1:]), span)
        negative = kids[0] is not None
        return ast.NumberNode(self.number(_token(kids[1]), negative=negative), span)


def _token(item: Tree[Token] | Token | None) -> Token:
    assert isinstance(item, Token)
    return item
