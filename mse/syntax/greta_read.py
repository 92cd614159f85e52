"""Reading Greta's XML: safe parsing, positions, signals and ``<con>`` trees.

Greta's files name a DTD by relative path; it is never fetched (the native reader's safe
parser is reused: no DTD loading, no entities, no network, BOM accepted, entity
declarations refused with E103).  Every problem carries a ``path:line:col`` span.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from lxml import etree

from mse.diagnostics import Diagnostic, MseError, Span
from mse.limits import parse_double, time_problem
from mse.syntax.greta_expr import (
    Edge,
    GAnd,
    GCompare,
    GExists,
    GExpr,
    GNot,
    GOr,
    GRelation,
    GTime,
)
from mse.syntax.reader import parse_xml, read_bytes
from mse.syntax.safexml import XmlDocument
from mse.syntax.source import SourceText

#: Greta's own ``equal`` accepts this difference (seconds).
GRETA_EQUAL_TOLERANCE = 0.3

#: Deeper ``<con>`` trees are refused (E111) rather than exhausting the stack.
MAX_CON_DEPTH = 100

_RELATIONS: dict[str, tuple[str, bool]] = {
    # Greta type -> (native relation, swap the arguments)
    "included": ("includes", True),  # included(A, B): A lies inside B
    "preceded": ("precedes", True),  # preceded(A, B): A comes after B has ended
    "rightinc": ("rightincludes", False),
    "excludes": ("excludes", False),
}
_COMPARISONS: dict[str, str] = {"morethan": ">", "lessthan": "<", "equal": "="}


class GretaFile(XmlDocument):
    """One parsed Greta file: the root element and positions of elements/attributes."""

    def __init__(self, path: str, root: etree._Element, source: SourceText) -> None:
        super().__init__(path, root, source)
        self.name = Path(path).name


def load(path: str | Path) -> GretaFile:
    """Parse ``path`` safely; raises MseError (E100/E101/E103/E104) when it cannot."""
    name = str(path)
    data, problems = read_bytes(path)
    if data is None:
        raise MseError(problems)
    root, source, problems = parse_xml(data, name)
    if root is None:
        raise MseError(problems)
    return GretaFile(name, root, source)


def elements(parent: etree._Element, tag: str) -> list[etree._Element]:
    return [child for child in parent if child.tag == tag]


def native_id(greta_id: str) -> str | None:
    """Greta signal id N -> ``sN`` (Greta ids are integers; leading zeros do not count)."""
    text = greta_id.strip()
    return f"s{int(text)}" if re.fullmatch(r"[0-9]{1,18}", text) else None


def format_number(value: float) -> str:
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") else text


# -- signals ------------------------------------------------------------------------------
@dataclass(frozen=True)
class GretaSignal:
    greta_id: str
    id: str
    lexeme: str
    modality: str
    attributes: dict[str, str]  # native attribute -> value text, only those Greta states
    excludelist: tuple[str, ...]
    span: Span
    excludelist_span: Span
    dropped: dict[str, str] = field(default_factory=dict)  # Greta-only attributes

    @property
    def bare_name(self) -> str:
        """The name without its class prefix (``faceexp=smile`` -> ``smile``)."""
        return self.lexeme.split("=", 1)[1] if "=" in self.lexeme else self.lexeme


#: Greta attribute -> native attribute, for lexicon.xml and for the legacy example.xml.
LEXICON_ATTRIBUTES = {
    "min": "min_duration",
    "max": "max_duration",
    "probability_start": "probability_start",
    "probability_end": "probability_end",
    "repetitivity": "repetitivity",
}
LEGACY_ATTRIBUTES = {
    "min_duration": "min_duration",
    "max_duration": "max_duration",
    "probability_start": "probability_start",
    "probability_end": "probability_end",
    "repetitivity": "repetitivity",
}


def read_signal(
    file: GretaFile,
    element: etree._Element,
    attribute_map: dict[str, str],
    modality_attribute: str,
    errors: list[Diagnostic],
) -> GretaSignal | None:
    """One ``<signal>``; invalid values are reported in ``errors`` (None when unusable)."""
    raw_id = element.get("id")
    identifier = native_id(raw_id) if raw_id is not None else None
    if identifier is None:
        errors.append(
            Diagnostic("E210", f"Greta signal id must be an integer, not {raw_id!r}",
                       file.attribute_span(element, "id"))
        )
        return None
    name = element.get("name")
    modality = element.get(modality_attribute)
    for attribute, value in (("name", name), (modality_attribute, modality)):
        if not value:
            errors.append(Diagnostic("E102", f"<signal> needs a '{attribute}' attribute",
                                     file.span(element)))
    if modality and not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", modality):
        errors.append(Diagnostic("E210", f"modality {modality!r} is not an identifier",
                                 file.attribute_span(element, modality_attribute)))
        modality = None
    values: dict[str, float] = {}
    for greta_name, native_name in attribute_map.items():
        text = element.get(greta_name)
        if text is None:
            continue
        where = file.attribute_span(element, greta_name)
        parsed = parse_double(text)  # xs:double with ASCII digits, as native files
        number = math.nan if parsed is None else parsed
        if not math.isfinite(number):
            message = f"{greta_name}={text[:60]!r} is not a finite number"
            errors.append(Diagnostic("E112", message, where))
            continue
        if native_name.endswith("_duration") and time_problem(number) is not None:
            errors.append(Diagnostic("E215", f"{greta_name}={text[:60]!r} {time_problem(number)}", where))
            continue
        problem = _value_problem(native_name, number)
        if problem is not None:
            errors.append(Diagnostic(problem[0], f"{greta_name}={text!r}: {problem[1]}", where))
            continue
        values[native_name] = number
    low, high = values.get("min_duration"), values.get("max_duration")
    if low is not None and high is not None and low > high:
        errors.append(Diagnostic("E205", f"min {format_number(low)} > max {format_number(high)}",
                                 file.span(element)))
    if not name or not modality:
        return None
    known = set(attribute_map) | {"id", "name", modality_attribute, "excludelist"}
    dropped = {str(k): str(v) for k, v in element.attrib.items() if k not in known}
    alternatives = [str(a.get("name") or "?") for a in elements(element, "alternative")]
    if alternatives:  # Greta's alternative shapes: the MSE language has one lexeme per signal
        dropped["<alternative>"] = ", ".join(alternatives)
    excludelist = tuple(
        entry.strip() for entry in (element.get("excludelist") or "").split(",") if entry.strip()
    )
    return GretaSignal(
        greta_id=raw_id or "",
        id=identifier,
        lexeme=name,
        modality=modality,
        attributes={
            key: (str(int(value)) if key == "repetitivity" else format_number(value))
            for key, value in values.items()
        },
        excludelist=excludelist,
        span=file.span(element),
        excludelist_span=file.attribute_span(element, "excludelist"),
        dropped=dropped,
    )


def _value_problem(native_name: str, value: float) -> tuple[str, str] | None:
    if native_name.endswith("_duration") and value < 0:
        return "E204", "a duration cannot be negative"
    if native_name.startswith("probability") and not 0.0 <= value <= 1.0:
        return "E206", "a probability must lie in [0, 1]"
    if native_name == "repetitivity" and value not in (0.0, 1.0):
        return "E207", "repetitivity must be 0 or 1"
    return None


# -- constraint trees ----------------------------------------------------------------------
class ConReader:
    """Turns ``<con>`` trees into :mod:`mse.syntax.greta_expr` trees."""

    def __init__(self, file: GretaFile, errors: list[Diagnostic], warnings: list[Diagnostic]):
        self.file = file
        self.errors = errors
        self.warnings = warnings

    def read(self, con: etree._Element, depth: int = 0) -> GExpr | None:
        span = self.file.span(con)
        if depth > MAX_CON_DEPTH:
            message = f"<con> nested deeper than {MAX_CON_DEPTH}"
            self.errors.append(Diagnostic("E111", message, span))
            return None
        kind = con.get("type") or ""
        args = elements(con, "arg")
        if kind in ("and", "or", "not"):
            reported = len(self.errors)
            operands = [self.read(sub, depth + 1) for sub in self._sub_cons(args, kind, span)]
            if len(self.errors) > reported or any(op is None for op in operands):
                return None
            present = [op for op in operands if op is not None]
            if kind == "not":
                if len(present) != 1:
                    self._error(span, f"'not' takes one constraint, found {len(present)}")
                    return None
                return GNot(present[0])
            if not present:
                self._error(span, f"'{kind}' has no operand")
                return None
            if len(present) == 1:
                return present[0]
            return GAnd(tuple(present)) if kind == "and" else GOr(tuple(present))
        if kind == "exists":
            ids = self._signal_args(args, 1, kind, span)
            return GExists(ids[0][0]) if ids else None
        if kind in _RELATIONS:
            ids = self._signal_args(args, 2, kind, span)
            if not ids:
                return None
            relation, swap = _RELATIONS[kind]
            left, right = (ids[1][0], ids[0][0]) if swap else (ids[0][0], ids[1][0])
            return GRelation(relation, left, right)  # type: ignore[arg-type]
        if kind in _COMPARISONS:
            ids = self._signal_args(args, 2, kind, span)
            if not ids:
                return None
            terms = [GTime(signal, edge) for signal, edge in ids]
            tolerance = GRETA_EQUAL_TOLERANCE if kind == "equal" else 0.0
            return GCompare(_COMPARISONS[kind], terms[0], terms[1], tolerance)  # type: ignore[arg-type]
        where = self.file.attribute_span(con, "type")
        self._error(where, f"unknown Greta constraint type {kind!r}")
        return None

    def _sub_cons(self, args: list[etree._Element], kind: str, span: Span) -> list[etree._Element]:
        found: list[etree._Element] = []
        for arg in args:
            subs = elements(arg, "con")
            if not subs:
                self._error(self.file.span(arg), f"an argument of '{kind}' must hold a <con>")
            found.extend(subs)
        return found

    def _signal_args(
        self, args: list[etree._Element], count: int, kind: str, span: Span
    ) -> list[tuple[str, Edge]]:
        """``(native id, edge)`` per argument; edge defaults to start (warned for comparisons)."""
        if len(args) != count:
            self._error(span, f"'{kind}' takes {count} argument(s), found {len(args)}")
            return []
        found: list[tuple[str, Edge]] = []
        for arg in args:
            where = self.file.span(arg)
            if elements(arg, "con"):
                self._error(where, f"an argument of '{kind}' must name a signal, not a <con>")
                return []
            raw = arg.get("id")
            identifier = native_id(raw) if raw is not None else None
            if identifier is None:
                self._error(where, f"argument id must be a Greta signal number, not {raw!r}")
                return []
            edge = arg.get("type")
            if edge not in (None, "start", "stop"):
                self._error(self.file.attribute_span(arg, "type"), f"argument type {edge!r} "
                            "is neither start nor stop")
                return []
            if edge is None and kind in _COMPARISONS:
                self.warnings.append(Diagnostic(
                    "W502", f"'{kind}' argument id={raw} has no start/stop type; read as "
                    f"start({identifier})",
                    where))
            found.append((identifier, "stop" if edge == "stop" else "start"))
        return found

    def _error(self, span: Span, message: str) -> None:
        self.errors.append(Diagnostic("E102", message, span))
