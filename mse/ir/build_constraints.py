"""One constraint's AST -> IR expression (build.py builds the model around it): signal names
resolved (E203 with a suggestion), seconds converted to ms ticks (E215), length differences
rewritten as comparisons of two times (E216 otherwise); long or deep expressions are built
without recursion."""

from __future__ import annotations

import difflib
from collections.abc import Callable

from mse.diagnostics import Span
from mse.ir import model as ir
from mse.ir.build_checker import BuildChecker
from mse.ir.relations import RELATIONS
from mse.limits import time_problem
from mse.syntax import ast


class ConstraintResolver:
    """Resolves names and converts seconds to ms ticks inside one constraint."""

    def __init__(self, signal_ids: set[str], constraint_id: str, checker: BuildChecker) -> None:
        self.signal_ids = signal_ids
        self.constraint_id = constraint_id
        self.checker = checker

    def signal(self, name: ast.Name) -> str:
        if name.text not in self.signal_ids:
            guess = difflib.get_close_matches(name.text, sorted(self.signal_ids), n=1, cutoff=0.6)
            hint = f" (did you mean {guess[0]!r}?)" if guess else ""
            self.checker.error(
                "E203", f"unknown signal {name.text!r} in constraint {self.constraint_id!r}{hint}", name.span
            )
        return name.text

    def ticks(self, value: float, span: Span, what: str) -> int:
        """Seconds to ms ticks, within the supported range (E215 otherwise)."""
        problem = time_problem(value)
        if problem is not None:
            self.checker.error("E215", f"{what} {value:g} {problem} (constraint {self.constraint_id!r})", span)
            return 0
        return self.checker.ticks(value, span, what)

    def term(self, node: ast.TermNode) -> ir.Term:
        if isinstance(node, ast.SignalTimeNode):
            edge: ir.Edge = "start" if node.edge == "start" else "stop"
            offset = self.ticks(node.offset, node.span, "offset")
            return ir.SignalTime(self.signal(node.signal), edge, offset, node.span)
        assert not isinstance(node, ast.DifferenceNode), "differences are built by _difference"
        if isinstance(node, ast.DurationNode):
            return ir.DurationTime(self.ticks(node.offset, node.span, "offset"), node.span)
        if isinstance(node, ast.SpeechTimeNode):
            anchor: ir.Anchor = node.anchor  # type: ignore[assignment]  # the parser spells only these
            return ir.SpeechTime(anchor, self.ticks(node.offset, node.span, "offset"), node.span)
        return ir.Constant(self.ticks(node.value, node.span, "time"), node.span)

    @staticmethod
    def operands(node: ast.NotNode | ast.BinaryNode) -> list[ast.ExprNode]:
        """The operands of ``node``; a chain of one connective (``a and b and c``, however
        parenthesised) is one n-ary node, gathered without recursion."""
        if isinstance(node, ast.NotNode):
            return [node.operand]
        if node.op == "implies":
            return [node.left, node.right]
        found: list[ast.ExprNode] = []
        pending: list[ast.ExprNode] = [node]
        while pending:
            current = pending.pop()
            if isinstance(current, ast.BinaryNode) and current.op == node.op:
                pending.append(current.right)
                pending.append(current.left)
            else:
                found.append(current)
        return found

    def expr(self, node: ast.ExprNode) -> ir.Expr:
        # Iterative post-order, so that very long or deep expressions do not recurse, and
        # each chain is built once (memory linear in the length of the expression).
        handlers: dict[type, Callable[[ast.ExprNode], ir.Expr]] = {
            ast.ExistsNode: self._exists,
            ast.RelationNode: self._relation,
            ast.CompareNode: self._compare,
        }
        results: dict[int, ir.Expr] = {}
        stack: list[tuple[ast.ExprNode, bool]] = [(node, False)]
        while stack:
            current, expanded = stack.pop()
            if isinstance(current, ast.NotNode | ast.BinaryNode):
                operands = self.operands(current)
                if not expanded:
                    stack.append((current, True))
                    stack.extend((operand, False) for operand in reversed(operands))
                    continue
                built = [results.pop(id(operand)) for operand in operands]
                results[id(current)] = connective(current, built)
            else:
                results[id(current)] = handlers[type(current)](current)
        return results[id(node)]

    def _exists(self, node: ast.ExprNode) -> ir.Expr:
        assert isinstance(node, ast.ExistsNode)
        return ir.Exists(self.signal(node.signal), node.span)

    def _relation(self, node: ast.ExprNode) -> ir.Expr:
        assert isinstance(node, ast.RelationNode)
        assert node.kind in RELATIONS  # the grammar spells only relations of the table
        return ir.Relation(node.kind, self.signal(node.left), self.signal(node.right), node.span)  # type: ignore[arg-type]

    def _compare(self, node: ast.ExprNode) -> ir.Expr:
        assert isinstance(node, ast.CompareNode)
        tolerance = 0
        if node.tolerance is not None:
            if node.tolerance.value < 0:
                self.checker.error(
                    "E208", f"tolerance {node.tolerance.value:g} must not be negative", node.tolerance.span
                )
            else:
                tolerance = self.ticks(node.tolerance.value, node.tolerance.span, "tolerance")
        op: ir.CompareOp = {"<": "<", ">": ">", "=": "=", "<=": "<=", ">=": ">="}[node.op]  # type: ignore[assignment]
        if isinstance(node.left, ast.DifferenceNode) or isinstance(node.right, ast.DifferenceNode):
            return self._difference(op, node, tolerance)
        return ir.Compare(op, self.term(node.left), self.term(node.right), tolerance, node.span)

    def _difference(self, op: ir.CompareOp, node: ast.CompareNode, tolerance: int) -> ir.Expr:
        """``stop(a) - start(b) + c op k`` (``length(a)`` is ``stop(a) - start(a)``) is the
        comparison of two times ``stop(a) op start(b) + (k - c)``: the same atom, evaluated
        and solved as every other one (docs/semantics.md).  A difference compared with
        anything but a number would need more than two times and is refused (E216)."""
        left, right = node.left, node.right
        if isinstance(left, ast.DifferenceNode) and isinstance(right, ast.NumberNode):
            shift = self.ticks(right.value - left.offset, right.span, "time")
            return ir.Compare(
                op, self._edge(left.minuend), self._edge(left.subtrahend, shift), tolerance, node.span
            )
        if isinstance(right, ast.DifferenceNode) and isinstance(left, ast.NumberNode):
            shift = self.ticks(left.value - right.offset, left.span, "time")
            return ir.Compare(
                op, self._edge(right.subtrahend, shift), self._edge(right.minuend), tolerance, node.span
            )
        other = right if isinstance(left, ast.DifferenceNode) else left
        self.checker.error(
            "E216",
            "a signal's length (length(s), or a difference such as stop(a) - start(b)) can only be "
            f"compared with a number (constraint {self.constraint_id!r})",
            other.span,
        )
        difference = left if isinstance(left, ast.DifferenceNode) else right
        assert isinstance(difference, ast.DifferenceNode)
        return ir.Exists(self.signal(difference.minuend.signal), node.span)  # a placeholder: E216 fails the build

    def _edge(self, node: ast.SignalTimeNode, offset: int = 0) -> ir.SignalTime:
        edge: ir.Edge = "start" if node.edge == "start" else "stop"
        return ir.SignalTime(self.signal(node.signal), edge, offset, node.span)


def connective(node: ast.NotNode | ast.BinaryNode, operands: list[ir.Expr]) -> ir.Expr:
    if isinstance(node, ast.NotNode):
        return ir.Not(operands[0], node.span)
    if node.op == "implies":
        return ir.Implies(operands[0], operands[1], node.span)
    kind = ir.And if node.op == "and" else ir.Or
    return kind(tuple(operands), node.span)
