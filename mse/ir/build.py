"""AST -> resolved Model, with every semantic check (E2xx) of a file reported at once.

The checker that collects them is build_checker.py's; each constraint's expression is resolved
by build_constraints.py."""

from __future__ import annotations

import math
import re

from mse.diagnostics import Diagnostic, Span, has_errors
from mse.ir import model as ir
from mse.ir.build_checker import BuildChecker
from mse.ir.build_constraints import ConstraintResolver
from mse.limits import xml_char_problem
from mse.syntax import ast

IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
EXPRESSION_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*\Z")


def build_model(document: ast.Document) -> tuple[ir.Model | None, list[Diagnostic]]:
    """Resolve and validate ``document``; the model is None when there are errors."""
    checker = BuildChecker(document.path)
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


def _expression_name(document: ast.Document, checker: BuildChecker) -> str:
    if document.name is None:
        return "expression"
    if not EXPRESSION_NAME.match(document.name.value):
        checker.error("E210", f"expression name {document.name.value!r} is not an identifier", document.name.span)
    return document.name.value


def _modalities(document: ast.Document, checker: BuildChecker) -> list[ir.Modality]:
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


def _signals(document: ast.Document, checker: BuildChecker) -> list[ir.Signal]:
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
        intensity = checker.number(attributes, "intensity", 1.0, minimum=0.0, maximum=1.0, code="E204")
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
                intensity=intensity,
            )
        )
    return result


def _repetitivity(attributes: dict[str, ast.Attribute], checker: BuildChecker) -> int:
    attribute = attributes.get("repetitivity")
    if attribute is None:
        return 0
    text = attribute.value.strip()
    if text not in ("0", "1"):
        checker.error("E207", f"repetitivity={attribute.value!r} must be 0 or 1", attribute.span)
        return 0
    return int(text)


def _motion(declaration: ast.MotionDecl | None, checker: BuildChecker) -> ir.MotionLeaf | None:
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


def _constraints(document: ast.Document, signal_ids: set[str], checker: BuildChecker) -> list[ir.Constraint]:
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
        resolver = ConstraintResolver(signal_ids, constraint_id, checker)
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


