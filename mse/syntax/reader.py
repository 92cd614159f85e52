"""Reading a native behaviour-set file: safe XML, the schema, and a positioned AST.

Safety: files are read through :func:`mse.input_files.read_input` (regular files only, at most
MAX_INPUT_BYTES); lxml parses without entity substitution, DTD loading or network, with
libxml2's entity-amplification limits.  The decision on entities is taken on the *parsed*
DOCTYPE: a document that declares any entity, or refers to one that is not predefined, is
refused (E103).  Text content (constraints) is taken from the parsed tree; the raw text is
only scanned, linearly, for positions.  All problems of a file are returned together.
"""

from __future__ import annotations

import difflib
import functools
import re
from pathlib import Path

from lxml import etree

from mse.diagnostics import Diagnostic, MseError, Span
from mse.input_files import read_input
from mse.limits import MAX_CONSTRAINT_CHARS, MAX_CONSTRAINT_TEXT, MAX_ELEMENTS, MAX_SIGNALS
from mse.resources import grammar_dir
from mse.syntax import ast
from mse.syntax.expression import parse_expression
from mse.syntax.safexml import MAX_FILE_BYTES, ElementPositions, decode_text, parse_xml, safe_parser
from mse.syntax.source import SourceText

__all__ = ["MAX_FILE_BYTES", "decode_text", "parse_xml", "read_bytes", "read_document", "safe_parser"]

MAX_CONSTRAINT_TEXT_PER_FILE = MAX_CONSTRAINT_TEXT


@functools.cache
def _schema() -> etree.XMLSchema:
    return etree.XMLSchema(etree.parse(str(grammar_dir() / "mse.xsd")))


_XS = "{http://www.w3.org/2001/XMLSchema}"
_REFUSED_ATTRIBUTE = re.compile(r"^Element '([^']+)', attribute '([^']+)': The attribute '[^']+' is not allowed")


@functools.cache
def _schema_attributes() -> dict[str, tuple[str, ...]]:
    """Element name -> the attributes the schema declares on it (for did-you-mean hints)."""
    declared: dict[str, tuple[str, ...]] = {}
    for element in etree.parse(str(grammar_dir() / "mse.xsd")).iter(f"{_XS}element"):
        complex_type = element.find(f"{_XS}complexType")
        if complex_type is None or element.get("name") is None:
            continue
        names = tuple(str(a.get("name")) for a in complex_type.findall(f"{_XS}attribute") if a.get("name"))
        declared[str(element.get("name"))] = names
    return declared


def _attribute_hint(element: str, attribute: str) -> str:
    """' (did you mean 'x'?)' for a misspelt attribute the schema refuses on ``element``."""
    allowed = _schema_attributes().get(element, ())
    guess = difflib.get_close_matches(attribute, allowed, n=1, cutoff=0.6)
    return f" (did you mean {guess[0]!r}?)" if guess else ""


def read_bytes(path: str | Path) -> tuple[bytes | None, list[Diagnostic]]:
    """The bytes of ``path``, or a diagnostic (missing, unreadable, not a regular file,
    too large)."""
    try:
        return read_input(path, what="behaviour-set file"), []
    except MseError as error:
        return None, list(error.diagnostics)


def _line(element: etree._Element) -> int:
    line = getattr(element, "sourceline", None)
    return line if isinstance(line, int) else 0


class _Locator:
    """Positions of elements and attributes (:class:`ElementPositions`), attributes as AST values."""

    def __init__(self, root: etree._Element, source: SourceText) -> None:
        self.source = source
        self.positions = ElementPositions(root, source)

    def element(self, element: etree._Element) -> Span:
        return self.positions.span(element)

    def attributes(self, element: etree._Element) -> dict[str, ast.Attribute]:
        spans = self.positions.attribute_spans(element)
        fallback = self.element(element)
        return {
            str(name): ast.Attribute(str(value), spans.get(str(name), fallback))
            for name, value in element.attrib.items()
        }


def _schema_diagnostics(root: etree._Element, locator: _Locator, path: str) -> list[Diagnostic]:
    schema = _schema()
    if schema.validate(etree.ElementTree(root)):
        return []
    by_line: dict[int, etree._Element] = {}
    for element in root.iter():
        if isinstance(element.tag, str) and _line(element):
            by_line.setdefault(_line(element), element)
    found: list[Diagnostic] = []
    for entry in schema.error_log:  # type: ignore[attr-defined]
        found_element = by_line.get(entry.line)
        span = (
            locator.element(found_element)
            if found_element is not None
            else Span(path, entry.line, max(entry.column, 1))
        )
        message = re.sub(r"^Element '([^']+)'(, attribute '([^']+)')?: ", _schema_prefix, entry.message)
        refused = re.match(_REFUSED_ATTRIBUTE, entry.message)
        if refused is not None:
            attribute = refused.group(2)
            message += _attribute_hint(refused.group(1), attribute)
            if found_element is not None:  # point at the attribute itself, not its element
                span = locator.attributes(found_element).get(attribute, ast.Attribute("", span)).span
        found.append(Diagnostic("E102", message, span))
    return found


def _schema_prefix(match: re.Match[str]) -> str:
    if match.group(3):
        return f"<{match.group(1)}> attribute '{match.group(3)}': "
    return f"<{match.group(1)}>: "


def read_document(path: str | Path, data: bytes | None = None) -> tuple[ast.Document | None, list[Diagnostic]]:
    """Parse a native file into a Document; also returns every diagnostic found."""
    name = str(path)
    if data is None:
        data, problems = read_bytes(path)
        if data is None:
            return None, problems
    root, source, problems = parse_xml(data, name, max_elements=MAX_ELEMENTS)
    if root is None:
        return None, problems
    signals = _count(root, "count(/expression/signals/signal)")  # in C, before per-signal work
    if signals > MAX_SIGNALS:
        message = f"{signals} signals; the limit is {MAX_SIGNALS}"
        return None, [Diagnostic("E104", message, source.line_span(_line(root)))]
    locator = _Locator(root, source)
    diagnostics = _schema_diagnostics(root, locator, name)
    if root.tag != "expression":
        return None, diagnostics or [
            Diagnostic("E102", f"root element must be <expression>, not <{root.tag}>", locator.element(root))
        ]
    document = _build_document(root, locator, name, diagnostics)
    return document, diagnostics


def _count(root: etree._Element, xpath: str) -> int:
    found = root.xpath(xpath)
    return int(found) if isinstance(found, float) else 0


def _children(element: etree._Element, tag: str) -> list[etree._Element]:
    return [child for child in element if child.tag == tag]


def _build_document(root: etree._Element, locator: _Locator, path: str, diagnostics: list[Diagnostic]) -> ast.Document:
    root_attributes = locator.attributes(root)
    description = " ".join(
        " ".join("".join(str(t) for t in d.itertext()).split()) for d in _children(root, "description")
    )
    modalities = tuple(
        ast.ModalityDecl(
            name=attributes.get("name", ast.Attribute("", locator.element(element))),
            exclusive=attributes.get("exclusive"),
            span=locator.element(element),
        )
        for element in _children(root, "modality")
        for attributes in [locator.attributes(element)]
    )
    signals_elements = _children(root, "signals")
    signals: list[ast.SignalDecl] = []
    for container in signals_elements:
        for element in _children(container, "signal"):
            motions = _children(element, "motion")
            motion = ast.MotionDecl(locator.attributes(motions[0]), locator.element(motions[0])) if motions else None
            signals.append(ast.SignalDecl(locator.attributes(element), motion, locator.element(element)))
    constraints: list[ast.ConstraintDecl] = []
    budget = [MAX_CONSTRAINT_TEXT_PER_FILE]
    for container in _children(root, "constraints"):
        for element in _children(container, "constraint"):
            constraints.append(_constraint(element, locator, diagnostics, budget))
    return ast.Document(
        path=path,
        name=root_attributes.get("name"),
        description=description,
        modalities=modalities,
        signals=tuple(signals),
        constraints=tuple(constraints),
        span=locator.element(root),
        has_signals_element=bool(signals_elements),
    )


def constraint_text(element: etree._Element) -> str:
    """The character data of a constraint as XML defines it: its text and the text after
    each comment or processing instruction inside it (those are not part of the text)."""
    parts = [element.text or ""]
    parts.extend(child.tail or "" for child in element)
    return "".join(parts)


def _constraint(
    element: etree._Element, locator: _Locator, diagnostics: list[Diagnostic], budget: list[int]
) -> ast.ConstraintDecl:
    attributes = locator.attributes(element)
    span = locator.element(element)
    text = constraint_text(element)
    if len(text) > MAX_CONSTRAINT_CHARS or len(text) > budget[0]:
        limit = MAX_CONSTRAINT_CHARS if len(text) > MAX_CONSTRAINT_CHARS else MAX_CONSTRAINT_TEXT_PER_FILE
        what = "constraint" if limit == MAX_CONSTRAINT_CHARS else "constraint text of the file"
        if budget[0] >= 0:  # once per file
            diagnostics.append(Diagnostic("E104", f"{what} is longer than {limit} characters", span))
        budget[0] = -1
        return ast.ConstraintDecl(attributes.get("id"), "", None, span)
    budget[0] -= len(text)
    tag = locator.positions.start_tag(element)
    decoded = locator.source.decode_content(tag) if tag is not None else None
    if decoded is not None and decoded.text == text:
        offsets = decoded.raw_offsets
        end = decoded.end_offset

        def locate(offset: int) -> Span:
            raw = offsets[offset] if offset < len(offsets) else end
            return locator.source.span_at(raw)
    else:  # the raw scan disagrees with the parsed tree: the tree decides, positions coarsen

        def locate(offset: int) -> Span:
            return span

    expr, problems = parse_expression(text, locate)
    diagnostics.extend(problems)
    return ast.ConstraintDecl(attributes.get("id"), " ".join(text.split()), expr, span)
