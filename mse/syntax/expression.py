"""Constraint expression text -> positioned AST, with the lark grammar as package data.

Positions: lark reports offsets inside the expression text; the caller passes ``locate``,
which turns an offset into the :class:`Span` of that character in the host file (the XML
file, with entities and CDATA accounted for).  Nothing outside this module sees lark.
"""

from __future__ import annotations

import difflib
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

KEYWORDS = (
    "exists", "includes", "excludes", "precedes", "rightincludes", "lessthan", "morethan", "equal",
    "start", "stop", "length", "duration", "and", "or", "not", "implies", "stressed",
)  # fmt: skip

_TOKEN_LABELS = {
    "LPAR": "'('",
    "RPAR": "')'",
    "COMMA": "','",
    "SIG": "a signal name",
    "NUMBER": "a number",
    "MINUS": "'-'",
    "PLUS": "'+'",
    "EDGE": "start(...) or stop(...)",
    "LENGTH": "length(...)",
    "DURATION": "'duration'",
    "ANCHOR": "speech.start, speech.stop or stressed",
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
    """The LALR parser, built once per process (about 50 ms).  Never lark's ``cache=True``:
    it unpickles a file from the shared temporary folder, which anyone can write."""
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
        guess = difflib.get_close_matches(str(token), KEYWORDS, n=1, cutoff=0.75) if token.type == "SIG" else []
        if guess and guess[0] != str(token):
            message = f"unknown operator {str(token)!r} (did you mean {guess[0]!r}?)"
        elif guess:  # a keyword where it cannot stand: never suggest the word itself
            message = f"{str(token)!r} cannot stand here in a constraint; expected {expected}"
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
    """Nesting depth of a parse tree without recursion; a chain of the same connective
    (``a and b and c``) counts as one level, as it becomes one n-ary node."""
    deepest = 0
    stack: list[tuple[Tree[Token], int]] = [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        for child in node.children:
            if isinstance(child, Tree):
                same_chain = child.data == node.data and node.data in ("and_", "or_")
                stack.append((child, depth if same_chain else depth + 1))
    return deepest


def _paren_depth(text: str) -> tuple[int, int]:
    """Deepest parenthesis nesting and the offset where it is reached."""
    depth = deepest = where = 0
    for offset, char in enumerate(text):
        if char == "(":
            depth += 1
            if depth > deepest:
                deepest, where = depth, offset
        elif char == ")":
            depth -= 1
    return deepest, where


def parse_expression(text: str, locate: Locate) -> tuple[ast.ExprNode | None, list[Diagnostic]]:
    """Parse one constraint's text; on error return None and the diagnostics."""
    if not text.strip():
        return None, [Diagnostic("E110", "empty constraint", locate(0))]
    parens, where = _paren_depth(text)
    if parens > MAX_DEPTH:
        return None, [Diagnostic("E111", f"constraint nested more than {MAX_DEPTH} levels deep", locate(where))]
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
        if kind in ("and_", "or_"):
            return self.chain(node)
        if kind == "implies":
            return ast.BinaryNode("implies", self.expr(kids[0]), self.expr(kids[2]), span)
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
                assert isinstance(kids[3], Tree)
                sign, tol_token = kids[3].children
                value = self.number(_token(tol_token), negative=sign is not None)
                tolerance = ast.NumberNode(value, self.span(kids[3]))
            return ast.CompareNode("=", self.term(kids[1]), self.term(kids[2]), tolerance, span)
        if kind == "compare":
            return ast.CompareNode(str(_token(kids[1])), self.term(kids[0]), self.term(kids[2]), None, span)
        raise AssertionError(f"unexpected parse node {kind}")  # pragma: no cover

    def chain(self, node: Tree[Token]) -> ast.ExprNode:
        """A left-recursive ``a and b and c`` chain, walked without recursion."""
        kind = node.data
        spine: list[Tree[Token]] = []
        current: Tree[Token] | Token | None = node
        while isinstance(current, Tree) and current.data == kind:
            spine.append(current)
            current = current.children[0]
        assert current is not None
        result = self.expr(current)
        op = "and" if kind == "and_" else "or"
        for link in reversed(spine):
            result = ast.BinaryNode(op, result, self.expr(link.children[2]), self.span(link))
        return result

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
        if kind == "difference":
            minuend = ast.SignalTimeNode(self.name(_token(kids[1])), str(_token(kids[0])), 0.0, span)
            subtrahend_span = self.span(_token(kids[3]))
            subtrahend = ast.SignalTimeNode(self.name(_token(kids[4])), str(_token(kids[3])), 0.0, subtrahend_span)
            return ast.DifferenceNode(minuend, subtrahend, self.offsets(kids[5:]), span)
        if kind == "length":
            signal = self.name(_token(kids[1]))
            return ast.DifferenceNode(
                ast.SignalTimeNode(signal, "stop", 0.0, span),
                ast.SignalTimeNode(signal, "start", 0.0, span),
                self.offsets(kids[2:]),
                span,
            )
        if kind == "duration_time":
            return ast.DurationNode(self.offsets(kids[1:]), span)
        if kind == "speech_time":
            return ast.SpeechTimeNode(_ANCHORS[str(_token(kids[0]))], self.offsets(kids[1:]), span)
        negative = kids[0] is not None
        return ast.NumberNode(self.number(_token(kids[1]), negative=negative), span)


#: Each spelling of a speech anchor and the anchor it names (mse.ir.model.SpeechTime).
_ANCHORS = {
    "speech.start": "start",
    "speech.stop": "stop",
    "stressed": "stressed_start",
    "stressed.start": "stressed_start",
    "stressed.stop": "stressed_stop",
}


def _token(item: Tree[Token] | Token | None) -> Token:
    assert isinstance(item, Token)
    return item
