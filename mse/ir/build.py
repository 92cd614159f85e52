"""AST -> resolved Model, with every semantic check (E2xx) of a file reported at once."""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Callable

from mse.diagnostics import Diagnostic, Span, has_errors
from mse.ir import model as ir
from mse.ir.schedule import to_ticks
from mse.limits import parse_double, parse_integer, time_problem, xml_char_problem
from mse.syntax import ast

IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
EXPRESSION_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*\Z")


class _Checker:
    def __init__(self, path: str) -> None:
        self.path = path
        self.diagnostics: list[Diagnostic] = []

    def error(self, code: str, message: str, span: Span) -> None:
        self.diagnostics.append(Diagnostic(code, message, span))

    def number(
        self,
        attributes: dict[str, ast.Attribute],
        key: str,
        default: float,
        *,
        minimum: float | None = None,
        maximum: float | None = None,
        code: str = "E204",
    ) -> float:
        attribute = attributes.get(key)
        if attribute is None:
            return default
        parsed = parse_double(attribute.value)
        if parsed is None:
            special = attribute.value.strip().lower().lstrip("+-") in ("nan", "inf", "infinity")
            reason = "must be a finite number" if special else "is not a number"
            self.error("E204", f"{key}={attribute.value[:60]!r} {reason}", attribute.span)
            return default
        value = parsed
        if not math.isfinite(value):
            self.error("E204", f"{key}={attribute.value[:60]!r} must be a finite number", attribute.span)
            return default
        if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
            bounds = f"in [{minimum:g}, {maximum:g}]" if maximum is not None else f">= {minimum:g}"
            self.error(code, f"{key}={attribute.value[:60]} must be {bounds}", attribute.span)
            return default
        return value

    def seconds(self, attributes: dict[str, ast.Attribute], key: str, default: float) -> float:
        """A duration attribute: a number in [0, MAX_SECONDS] (E204, E215)."""
        value = self.number(attributes, key, default, minimum=0.0)
        attribute = attributes.get(key)
        problem = time_problem(value, minimum=0.0) if attribute is not None and math.isfinite(value) else None
        if attribute is not None and problem is not None:
            self.error("E215", f"{key}={attribute.value[:60]} {problem}", attribute.span)
            return default
        return value

    def ticks(self, seconds: float, span: Span, what: str) -> int:
        """``seconds`` on the 1 ms grid, with a W309 warning when that rounds it."""
        ticks = to_ticks(seconds)
        if abs(seconds * 1000 - ticks) > 1e-6:
            self.error("W309", f"{what} {seconds:g} s is finer than the 1 ms grid of the semantics: "
                       f"it is rounded to {ticks / 1000:g} s", span)
        return ticks

    def integer(self, attributes: dict[str, ast.Attribute], key: str, default: int, *, minimum: int, code: str) -> int:
        attribute = attributes.get(key)
        if attribute is None:
            return default
        value = parse_integer(attribute.value)
        if value is None or value < minimum:
            self.error(
                code,
                f"{key}={attribute.value[:60]!r} must be a whole number >= {minimum} (at most 9 digits)",
                attribute.span,
            )
            return default
        return value


def build_model(document: ast.Document) -> tuple[ir.Model | None, list[Diagnostic]]:
    """Resolve and validate ``document``; the model is None when there are errors."""
    checker = _Checker(document.path)
    name = _expression_name(document, checker)
    modalities = _modalities(document, checker)
    signals = _signals(document, checker)
    constraints = _constraints(document, {s.id for s in signals}, checker)
    problem = xml_char_problem(document.description)
    if problem is not None:
        checker.error("E204", f"description {problem}", document.span)
    if has_errors(checker.diagnostics):
        return None, checker.diagnostics
    return (
        ir.Model(
            name=name,
            signals=tuple(signals),
            constraints=tuple(constraints),
            modalities=tuple(modalities),
            description=document.description,
            path=document.path,
        ),
        checker.diagnostics,  # warnings only (W309)
    )


def _expression_name(document: ast.Document, checker: _Checker) -> str:
    if document.name is None:
        return "expression"
    if not EXPRESSION_NAME.match(document.name.value):
        checker.error("E210", f"expression name {document.name.value!r} is not an identifier", document.name.span)
    return document.name.value


def _modalities(document: ast.Document, checker: _Checker) -> list[ir.Modality]:
    seen: set[str] = set()
    result: list[ir.Modality] = []
    for declaration in document.modalities:
        name = declaration.name.value
        if not IDENTIFIER.match(name):
            checker.error("E210", f"modality name {name!r} is not an identifier", declaration.name.span)
            continue
        if name in seen:
            checker.error("E211", f"modality {name!r} is declared twice", declaration.span)
            continue
        seen.add(name)
        exclusive = declaration.exclusive is not None and declaration.exclusive.value.strip() in ("true", "1")
        result.append(ir.Modality(name, exclusive, declaration.span))
    return result


def _signals(document: ast.Document, checker: _Checker) -> list[ir.Signal]:
    if not document.signals:
        checker.error("E209", "the expression declares no signal", document.span)
        return []
    seen: dict[str, Span] = {}
    result: list[ir.Signal] = []
    for declaration in document.signals:
        attributes = declaration.attributes
        id_attribute = attributes.get("id", ast.Attribute("", declaration.span))
        signal_id = id_attribute.value
        if not IDENTIFIER.match(signal_id):
            checker.error(
                "E210", f"signal id {signal_id!r} is not an identifier ([A-Za-z_][A-Za-z0-9_]*)", id_attribute.span
            )
        elif signal_id in seen:
            first = seen[signal_id]
            checker.error(
                "E201", f"duplicate signal id {signal_id!r} (first declared at line {first.line})", id_attribute.span
            )
        seen.setdefault(signal_id, id_attribute.span)
        minimum = checker.seconds(attributes, "min_duration", 0.0)
        maximum_value = checker.seconds(attributes, "max_duration", math.inf)
        maximum = None if math.isinf(maximum_value) else maximum_value
        for key, value in (("min_duration", minimum), ("max_duration", maximum)):
            if key in attributes and value is not None:
                checker.ticks(value, attributes[key].span, key)
        if maximum is not None and minimum > maximum:
            span = attributes["min_duration"].span
            checker.error("E205", f"min_duration {minimum:g} is greater than max_duration {maximum:g}", span)
        if maximum is not None and maximum == 0:
            checker.error("E204", "max_duration must be greater than 0", attributes["max_duration"].span)
        p_start = checker.number(attributes, "probability_start", 1.0, minimum=0.0, maximum=1.0, code="E206")
        p_end = checker.number(attributes, "probability_end", 1.0, minimum=0.0, maximum=1.0, code="E206")
        repetitivity = _repetitivity(attributes, checker)
        max_occurrences = (
            checker.integer(attributes, "max_occurrences", 1, minimum=1, code="E204")
            if "max_occurrences" in attributes
            else None
        )
        modality = attributes.get("modality", ast.Attribute("", declaration.span)).value.strip()
        if modality and not IDENTIFIER.match(modality):
            checker.error("E210", f"modality {modality!r} is not an identifier", attributes["modality"].span)
        lexeme = attributes["lexeme"].value.strip() if "lexeme" in attributes else signal_id
        problem = xml_char_problem(lexeme)
        if problem is not None:  # only compiled IR (JSON) can carry these; exports could not
            checker.error("E204", f"lexeme {problem}", attributes.get("lexeme", id_attribute).span)
            lexeme = signal_id
        result.append(
            ir.Signal(
                id=signal_id,
                modality=modality,
                lexeme=lexeme or signal_id,
                min_duration=minimum,
                max_duration=maximum,
                probability_start=p_start,
                probability_end=p_end,
                repetitivity=repetitivity,
                max_occurrences=max_occurrences,
                motion=_motion(declaration.motion, checker),
                span=id_attribute.span,
            )
        )
    return result


def _repetitivity(attributes: dict[str, ast.Attribute], checker: _Checker) -> int:
    attribute = attributes.get("repetitivity")
    if attribute is None:
        return 0
    text = attribute.value.strip()
    if text not in ("0", "1"):
        checker.error("E207", f"repetitivity={attribute.value!r} must be 0 or 1", attribute.span)
        return 0
    return int(text)


def _motion(declaration: ast.MotionDecl | None, checker: _Checker) -> ir.MotionLeaf | None:
    if declaration is None:
        return None
    attributes = declaration.attributes
    action = attributes.get("action", ast.Attribute("", declaration.span))
    if not IDENTIFIER.match(action.value):
        checker.error("E213", f"motion action {action.value!r} is not an identifier", action.span)
    for key, value in attributes.items():
        problem = xml_char_problem(key + value.value)
        if problem is not None:
            checker.error("E213", f"motion attribute {key[:40]!r} {problem}", value.span)
    method = attributes["method"].value if "method" in attributes else "lma-hmm"
    if method not in ("lma-hmm", "hsmm"):
        checker.error("E213", f"motion method {method!r} is not one of lma-hmm, hsmm", attributes["method"].span)
    return ir.MotionLeaf(
        action=action.value,
        clip=attributes["clip"].value if "clip" in attributes else None,
        nd=checker.integer(attributes, "nd", 0, minimum=0, code="E213"),
        states=checker.integer(attributes, "states", 12, minimum=1, code="E213"),
        method=method,
        attributes={key: value.value for key, value in attributes.items()},
        span=declaration.span,
    )


def _constraints(document: ast.Document, signal_ids: set[str], checker: _Checker) -> list[ir.Constraint]:
    explicit = {d.id.value for d in document.constraints if d.id is not None}
    seen: dict[str, Span] = {}
    result: list[ir.Constraint] = []
    for position, declaration in enumerate(document.constraints, start=1):
        if declaration.id is not None:
            constraint_id = declaration.id.value
            if not IDENTIFIER.match(constraint_id):
                checker.error("E210", f"constraint id {constraint_id!r} is not an identifier", declaration.id.span)
            elif constraint_id in seen:
                checker.error(
                    "E202",
                    f"duplicate constraint id {constraint_id!r} (first at line {seen[constraint_id].line})",
                    declaration.id.span,
                )
            seen.setdefault(constraint_id, declaration.id.span)
        else:
            constraint_id = f"c{position}"
            suffix = 1
            while constraint_id in explicit:
                suffix += 1
                constraint_id = f"c{position}_{suffix}"
        if declaration.expr is None:
            continue
        resolver = _Resolver(signal_ids, constraint_id, checker)
        expr = resolver.expr(declaration.expr)
        result.append(
            ir.Constraint(
                id=constraint_id,
                expr=expr,
                explicit_id=declaration.id is not None,
                text=declaration.text,
                span=declaration.span,
            )
        )
    return result


class _Resolver:
    """Resolves names and converts seconds to ms ticks inside one constraint."""

    def __init__(self, signal_ids: set[str], constraint_id: str, checker: _Checker) -> None:
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
                results[id(current)] = _connective(current, built)
            else:
                results[id(current)] = handlers[type(current)](current)
        return results[id(node)]

    def _exists(self, node: ast.ExprNode) -> ir.Expr:
        assert isinstance(node, ast.ExistsNode)
        return ir.Exists(self.signal(node.signal), node.span)

    def _relation(self, node: ast.ExprNode) -> ir.Expr:
        assert isinstance(node, ast.RelationNode)
        kind: ir.RelationKind = {
            "includes": "includes",
            "excludes": "excludes",
            "precedes": "precedes",
            "rightincludes": "rightincludes",
        }[node.kind]  # type: ignore[assignment]
        return ir.Relation(kind, self.signal(node.left), self.signal(node.right), node.span)

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


def _connective(node: ast.NotNode | ast.BinaryNode, operands: list[ir.Expr]) -> ir.Expr:
    if isinstance(node, ast.NotNode):
        return ir.Not(operands[0], node.span)
    if node.op == "implies":
        return ir.Implies(operands[0], operands[1], node.span)
    kind = ir.And if node.op == "and" else ir.Or
    return kind(tuple(operands), node.span)
