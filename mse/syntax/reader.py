"""Reading a native behaviour-set file: safe XML, the schema, and a positioned AST.

Safety: no entity resolution, no DTD loading, no network; a DOCTYPE that declares
entities is refused before parsing (an entity bomb fails at once), and files over 10 MB
are refused.  All problems of a file are collected and returned together.
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

from lxml import etree

from mse.diagnostics import Diagnostic, Span
from mse.resources import grammar_dir
from mse.syntax import ast
from mse.syntax.expression import parse_expression
from mse.syntax.source import SourceText, StartTag

MAX_FILE_BYTES = 10 * 1024 * 1024
_ENTITY_DECLARATION = re.compile(r"<!DOCTYPE[^\[>]*\[[^\]]*<!ENTITY", re.DOTALL)


@functools.cache
def _schema() -> etree.XMLSchema:
    return etree.XMLSchema(etree.parse(str(grammar_dir() / "mse.xsd")))


def safe_parser() -> etree.XMLParser:
    return etree.XMLParser(
        resolve_entities=False,
        load_dtd=False,
        dtd_validation=False,
        no_network=True,
        huge_tree=False,
        remove_blank_text=False,
    )


def read_bytes(path: str | Path) -> tuple[bytes | None, list[Diagnostic]]:
    """The bytes of ``path``, or a diagnostic (missing, unreadable, too large)."""
    name = str(path)
    try:
        target = Path(path)
        if target.is_dir():
            return None, [Diagnostic("E100", "is a directory, not a behaviour-set file", Span(name))]
        size = target.stat().st_size
        if size > MAX_FILE_BYTES:
            return None, [Diagnostic("E104", f"file is {size} bytes; the limit is {MAX_FILE_BYTES}", Span(name))]
        return target.read_bytes(), []
    except OSError as error:
        return None, [Diagnostic("E100", f"cannot read file: {error.strerror or error}", Span(name))]


def decode_text(data: bytes) -> str:
    text = data.decode("utf-8", errors="replace")
    return text[1:] if text.startswith("\ufeff") else text


def parse_xml(data: bytes, path: str) -> tuple[etree._Element | None, SourceText, list[Diagnostic]]:
    """Well-formedness and safety; returns the root element and the raw-text index."""
    text = decode_text(data)
    source = SourceText(path, text)
    if len(data) > MAX_FILE_BYTES:
        return None, source, [Diagnostic("E104", f"input is larger than {MAX_FILE_BYTES} bytes", Span(path))]
    entity = _ENTITY_DECLARATION.search(text)
    if entity:
        return (
            None,
            source,
            [
                Diagnostic(
                    "E103", "DOCTYPE declares entities; entity declarations are refused", source.span_at(entity.start())
                )
            ],
        )
    try:
        root = etree.fromstring(data, safe_parser())
    except etree.XMLSyntaxError as error:
        line, column = error.position
        message = re.sub(r", line \d+, column \d+$", "", str(error.msg or error))
        return None, source, [Diagnostic("E101", message, Span(path, line, column))]
    return root, source, []


def _line(element: etree._Element) -> int:
    line = getattr(element, "sourceline", None)
    return line if isinstance(line, int) else 0


class _Locator:
    """Pairs parsed elements with their start tags in the raw text."""

    def __init__(self, root: etree._Element, source: SourceText) -> None:
        self.source = source
        elements = [e for e in root.iter() if isinstance(e.tag, str)]
        tags = source.start_tags
        self.tags: dict[etree._Element, StartTag] = {}
        if len(elements) == len(tags) and all(
            etree.QName(e).localname == t.name.split(":")[-1] for e, t in zip(elements, tags, strict=True)
        ):
            self.tags = dict(zip(elements, tags, strict=True))

    def element(self, element: etree._Element) -> Span:
        tag = self.tags.get(element)
        if tag is not None:
            return self.source.span_at(tag.start)
        return self.source.line_span(_line(element))

    def attributes(self, element: etree._Element) -> dict[str, ast.Attribute]:
        tag = self.tags.get(element)
        spans = self.source.attribute_spans(tag) if tag is not None else {}
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
    root, source, problems = parse_xml(data, name)
    if root is None:
        return None, problems
    locator = _Locator(root, source)
    diagnostics = _schema_diagnostics(root, locator, name)
    if root.tag != "expression":
        return None, diagnostics or [
            Diagnostic("E102", f"root element must be <expression>, not <{root.tag}>", locator.element(root))
        ]
    document = _build_document(root, locator, name, diagnostics)
    return document, diagnostics


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
    for container in _children(root, "constraints"):
        for element in _children(container, "constraint"):
            constraints.append(_constraint(element, locator, diagnostics))
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


def _constraint(element: etree._Element, locator: _Locator, diagnostics: list[Diagnostic]) -> ast.ConstraintDecl:
    attributes = locator.attributes(element)
    span = locator.element(element)
    tag = locator.tags.get(element)
    if tag is not None:
        decoded = locator.source.decode_content(tag)
        text = decoded.text
        offsets = decoded.raw_offsets
        end = decoded.end_offset

        def locate(offset: int) -> Span:
            raw = offsets[offset] if offset < len(offsets) else end
            return locator.source.span_at(raw)
    else:
        text = element.text or ""

        def locate(offset: int) -> Span:
            return span

    expr, problems = parse_expression(text, locate)
    diagnostics.extend(problems)
    return ast.ConstraintDecl(attributes.get("id"), " ".join(text.split()), expr, span)
