"""Safe XML for every XML input of mse (behaviour sets, Greta files, face libraries).

lxml parses without entity substitution, DTD loading or network, with libxml2's entity
amplification limits (an entity bomb fails at once).  The decision on entities is taken on
the *parsed* DOCTYPE, never on a regular expression over the raw text: a document that
declares any entity, or refers to one that is not predefined (possible when it names an
external DTD, which is never loaded), is refused with E103.  The raw text is then indexed,
linearly, for positions (:class:`mse.syntax.source.SourceText`).
"""

from __future__ import annotations

import codecs

from lxml import etree

from mse.diagnostics import Diagnostic, Span
from mse.limits import MAX_INPUT_BYTES, MAX_XML_ELEMENTS
from mse.syntax.source import SourceText, StartTag

MAX_FILE_BYTES = MAX_INPUT_BYTES


def safe_parser() -> etree.XMLParser:
    return etree.XMLParser(
        resolve_entities=False,
        load_dtd=False,
        dtd_validation=False,
        no_network=True,
        huge_tree=False,
        remove_blank_text=False,
    )


_BOMS = (
    (codecs.BOM_UTF32_LE, "utf-32"),
    (codecs.BOM_UTF32_BE, "utf-32"),
    (codecs.BOM_UTF8, "utf-8-sig"),
    (codecs.BOM_UTF16_LE, "utf-16"),
    (codecs.BOM_UTF16_BE, "utf-16"),
)


def decode_text(data: bytes, encoding: str | None = None) -> str:
    """The document's text: a byte-order mark decides, else the encoding lxml detected
    (UTF-8 when unknown); undecodable bytes become U+FFFD (positions only)."""
    codec = "utf-8"
    for bom, name in _BOMS:
        if data.startswith(bom):
            codec = name
            break
    else:
        if encoding:
            try:
                codec = codecs.lookup(encoding).name
            except LookupError:
                codec = "utf-8"
    text = data.decode(codec, errors="replace")
    return text[1:] if text.startswith("\ufeff") else text


def _entity_problem(root: etree._Element, source: SourceText) -> Diagnostic | None:
    """E103 when the parsed document declares entities or refers to one that is not
    predefined (possible when an external DTD, never loaded, is named)."""
    dtd = root.getroottree().docinfo.internalDTD
    declared = [entity.name for entity in dtd.iterentities()] if dtd is not None else []  # type: ignore[attr-defined]
    if declared:
        where = source.find("<!ENTITY") or source.find("<!DOCTYPE") or Span(source.path, 1, 1)
        names = ", ".join(repr(str(name)) for name in declared[:3])
        return Diagnostic("E103", f"DOCTYPE declares entities ({names}); entity declarations are refused", where)
    for node in root.iter():
        if isinstance(node, etree._Entity):
            line = node.sourceline if isinstance(node.sourceline, int) else 0
            return Diagnostic("E103", f"reference to an undeclared entity {node.text}", source.line_span(line))
    if source.unknown_entities:
        return Diagnostic("E103", "reference to an undeclared entity", source.span_at(source.unknown_entities[0]))
    return None


def _escape_hint(message: str, data: bytes, line: int, column: int) -> str:
    """How to write the character that broke the parse, when it is a bare ``<`` or ``&`` in
    text (constraints use both: ``start(a) <= 2``, ``a and b`` is fine but ``&&`` is not)."""
    if "StartTag: invalid element name" in message and line > 1:  # inside a document, not its start
        return "; a '<' inside text must be written '&lt;' (e.g. start(a) &lt;= 2)"
    if "EntityRef: expecting ';'" in message or "xmlParseEntityRef: no name" in message:
        return "; a '&' inside text must be written '&amp;'"
    return ""


def parse_xml(
    data: bytes, path: str, *, max_elements: int = MAX_XML_ELEMENTS
) -> tuple[etree._Element | None, SourceText, list[Diagnostic]]:
    """Well-formedness and safety; returns the root element and the raw-text index.
    More than ``max_elements`` elements is E104 (counted in C, before any Python work)."""
    if len(data) > MAX_FILE_BYTES:
        empty = SourceText(path, "")
        return None, empty, [Diagnostic("E104", f"input is larger than {MAX_FILE_BYTES} bytes", Span(path))]
    try:
        root = etree.fromstring(data, safe_parser())
    except etree.XMLSyntaxError as error:
        line, column = error.position
        message = str(error.msg or error)
        suffix = message.rfind(", line ")
        if suffix >= 0 and ", column " in message[suffix:]:
            message = message[:suffix]
        if "amplification" in message or "entity reference loop" in message:  # an entity bomb
            source = SourceText(path, decode_text(data))
            where = source.find("<!ENTITY") or Span(path, line, column)
            return None, source, [Diagnostic("E103", "entity declarations are refused (entity expansion bomb)", where)]
        message = message.strip() + _escape_hint(message, data, line, column)
        return None, SourceText(path, ""), [Diagnostic("E101", message, Span(path, line, column))]
    count = root.xpath("count(//*)")
    if isinstance(count, float) and count > max_elements:
        line = root.sourceline if isinstance(root.sourceline, int) else 1
        message = f"{int(count)} elements; the limit is {max_elements}"
        return None, SourceText(path, ""), [Diagnostic("E104", message, Span(path, line, 1))]
    source = SourceText(path, decode_text(data, root.getroottree().docinfo.encoding))
    problem = _entity_problem(root, source)
    if problem is not None:
        return None, source, [problem]
    return root, source, []


class ElementPositions:
    """Where each parsed element and attribute stands in the raw text: lxml keeps an element's
    line only, so its elements are paired, in document order, with the start tags that
    :class:`SourceText` found (when the two lists disagree, lines are all there is)."""

    def __init__(self, root: etree._Element, source: SourceText) -> None:
        self.source = source
        elements = [e for e in root.iter() if isinstance(e.tag, str)]
        tags = source.start_tags
        self._tags: dict[etree._Element, StartTag] = {}
        if len(elements) == len(tags) and all(
            etree.QName(e).localname == t.name.rpartition(":")[2] for e, t in zip(elements, tags, strict=True)
        ):
            self._tags = dict(zip(elements, tags, strict=True))

    def start_tag(self, element: etree._Element) -> StartTag | None:
        return self._tags.get(element)

    def span(self, element: etree._Element) -> Span:
        tag = self._tags.get(element)
        if tag is not None:
            return self.source.span_at(tag.start)
        line = element.sourceline
        return self.source.line_span(line if isinstance(line, int) else 0)

    def attribute_spans(self, element: etree._Element) -> dict[str, Span]:
        tag = self._tags.get(element)
        return self.source.attribute_spans(tag) if tag is not None else {}

    def attribute_span(self, element: etree._Element, name: str) -> Span:
        found = self.attribute_spans(element).get(name)
        return found if found is not None else self.span(element)


class XmlDocument:
    """A safely parsed XML file (:func:`parse_xml`) and where each element and attribute of it
    stands, for diagnostics at file:line:col."""

    def __init__(self, path: str, root: etree._Element, source: SourceText) -> None:
        self.path = path
        self.root = root
        self.source = source
        self._positions = ElementPositions(root, source)

    def span(self, element: etree._Element) -> Span:
        return self._positions.span(element)

    def attribute_span(self, element: etree._Element, name: str) -> Span:
        return self._positions.attribute_span(element, name)
