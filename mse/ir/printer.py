"""Canonical text of constraint expressions: parsing the output gives the same IR."""

from __future__ import annotations

from mse.ir import model as ir
from mse.ir.schedule import to_seconds

# Binding strength: higher binds tighter.
_LEVEL = {ir.Implies: 1, ir.Or: 2, ir.And: 3, ir.Not: 4}
_ATOM_LEVEL = 5


def seconds(ticks: int) -> str:
    """Milliseconds as the shortest decimal number of seconds (``1500`` -> ``1.5``)."""
    text = f"{to_seconds(abs(ticks)):.3f}".rstrip("0").rstrip(".")
    return text or "0"


def _offset(ticks: int) -> str:
    if ticks == 0:
        return ""
    return f" {'+' if ticks > 0 else '-'} {seconds(ticks)}"


#: How each speech anchor is written (the grammar also reads ``stressed.start``).
ANCHOR_SPELLING = {
    "start": "speech.start",
    "stop": "speech.stop",
    "stressed_start": "stressed",
    "stressed_stop": "stressed.stop",
}


def term_text(term: ir.Term) -> str:
    if isinstance(term, ir.SignalTime):
        return f"{term.edge}({term.signal}){_offset(term.offset)}"
    if isinstance(term, ir.DurationTime):
        return f"duration{_offset(term.offset)}"
    if isinstance(term, ir.SpeechTime):
        return f"{ANCHOR_SPELLING[term.anchor]}{_offset(term.offset)}"
    return ("-" if term.value < 0 else "") + seconds(term.value)


def _constant_text(ticks: int) -> str:
    return ("-" if ticks < 0 else "") + seconds(ticks)


def _length_sides(atom: ir.Compare) -> tuple[str, str] | None:
    """``stop(a) op start(a) + k`` is what ``length(a) op k`` parses to (and ``start(a) + k op
    stop(a)`` is ``k op length(a)``): print it the way it is written.  Other offsets are left
    as two times, so that parsing the text gives back exactly this atom."""
    left, right = atom.left, atom.right
    if not (isinstance(left, ir.SignalTime) and isinstance(right, ir.SignalTime)) or left.signal != right.signal:
        return None
    length = f"length({left.signal})"
    if left.edge == "stop" and right.edge == "start" and left.offset == 0:
        return length, _constant_text(right.offset)
    if left.edge == "start" and right.edge == "stop" and right.offset == 0:
        return _constant_text(left.offset), length
    return None


def _atom_text(atom: ir.Atom) -> str:
    if isinstance(atom, ir.Exists):
        return f"exists({atom.signal})"
    if isinstance(atom, ir.Relation):
        return f"{atom.kind}({atom.left}, {atom.right})"
    left, right = _length_sides(atom) or (term_text(atom.left), term_text(atom.right))
    if atom.op == "=" and atom.tolerance:
        return f"equal({left}, {right}, {seconds(atom.tolerance)})"
    return f"{left} {atom.op} {right}"


def _level(expr: ir.Expr) -> int:
    return _LEVEL.get(type(expr), _ATOM_LEVEL)


def expr_text(expr: ir.Expr) -> str:
    """Minimal parentheses; ``implies`` is right-associative."""
    if isinstance(expr, ir.Not):
        inner = expr_text(expr.operand)
        return f"not {inner}" if _level(expr.operand) >= _LEVEL[ir.Not] else f"not ({inner})"
    if isinstance(expr, ir.And | ir.Or):
        word = " and " if isinstance(expr, ir.And) else " or "
        mine = _level(expr)
        # Nested operands of the same kind are parenthesised so that re-parsing (which
        # flattens) reproduces exactly this tree.
        parts = [expr_text(e) if _level(e) > mine else f"({expr_text(e)})" for e in expr.operands]
        return word.join(parts)
    if isinstance(expr, ir.Implies):
        left = expr_text(expr.left)
        if _level(expr.left) <= _LEVEL[ir.Implies]:
            left = f"({left})"
        right = expr_text(expr.right)
        if _level(expr.right) < _LEVEL[ir.Implies]:
            right = f"({right})"
        return f"{left} implies {right}"
    return _atom_text(expr)
