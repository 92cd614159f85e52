"""Positions in the raw text of an XML file.

lxml tells the line of an element but not its column, nor where an attribute or a
character of text content sits.  :class:`SourceText` scans the raw text once to find every
start tag (in document order, skipping comments, CDATA, processing instructions and the
DOCTYPE), so that element *k* of the parsed tree pairs with start tag *k*; it then maps
attribute names and decoded text offsets (entities, CDATA) back to ``line:col``.
"""

from __future__ import annotations

import bisect
import re
from dataclasses import dataclass

from mse.diagnostics import Span

_SKIP = re.compile(r"<!--.*?-->|<!\[CDATA\[.*?\]\]>|<\?.*?\?>|<!DOCTYPE(?:[^\[>]|\[.*?\])*>", re.DOTALL)
_START_TAG = re.compile(r"<([A-Za-z_][\w.\-]*(?::[A-Za-z_][\w.\-]*)?)")
_ATTRIBUTE = re.compile(r"""([A-Za-z_][\w.:\-]*)\s*=\s*("[^"]*"|'[^']*')""")
_ENTITY = re.compile(r"&(#x[0-9A-Fa-f]+|#[0-9]+|[A-Za-z]+);")
_NAMED = {"lt": "<", "gt": ">", "amp": "&", "quot": '"', "apos": "'"}


@dataclass(frozen=True, slots=True)
class StartTag:
    name: str
    start: int  # offset of '<'
    end: int  # offset just after '>'


@dataclass(frozen=True, slots=True)
class DecodedText:
    """Text content with, for each decoded character, its offset in the raw file."""

    text: str
    raw_offsets: tuple[int, ...]
    end_offset: int


class SourceText:
    def __init__(self, path: str, text: str) -> None:
        self.path = path
        self.text = text
        self._line_starts = [0] + [m.end() for m in re.finditer(r"\n", text)]
        self.start_tags = self._scan_start_tags()

    def span_at(self, offset: int) -> Span:
        line_index = bisect.bisect_right(self._line_starts, offset) - 1
        return Span(self.path, line_index + 1, offset - self._line_starts[line_index] + 1)

    def line_span(self, line: int) -> Span:
        """Column of the first non-blank character of ``line`` (1-based)."""
        if not 1 <= line <= len(self._line_starts):
            return Span(self.path, max(line, 0), 1 if line > 0 else 0)
        start = self._line_starts[line - 1]
        stripped = len(self.text[start:]) - len(self.text[start:].lstrip(" \t"))
        return Span(self.path, line, stripped + 1)

    def _scan_start_tags(self) -> list[StartTag]:
        tags: list[StartTag] = []
        position = 0
        text = self.text
        while True:
            lt = text.find("<", position)
            if lt < 0:
                return tags
            skipped = _SKIP.match(text, lt)
            if skipped:
                position = skipped.end()
                continue
            match = _START_TAG.match(text, lt)
            if not match:
                position = lt + 1
                continue
            end = self._tag_end(match.end())
            tags.append(StartTag(match.group(1), lt, end))
            position = end

    def _tag_end(self, position: int) -> int:
        """Offset after the '>' closing a start tag (quotes may hold '>')."""
        quote = ""
        text = self.text
        while position < len(text):
            char = text[position]
            if quote:
                if char == quote:
                    quote = ""
            elif char in "\"'":
                quote = char
            elif char == ">":
                return position + 1
            position += 1
        return len(text)

    def attribute_spans(self, tag: StartTag) -> dict[str, Span]:
        spans: dict[str, Span] = {}
        body = self.text[tag.start : tag.end]
        for match in _ATTRIBUTE.finditer(body):
            spans.setdefault(match.group(1), self.span_at(tag.start + match.start(1)))
        return spans

    def decode_content(self, tag: StartTag) -> DecodedText:
        """Decode the text content after ``tag`` up to the next tag (comments and CDATA
        sections included), keeping each character's raw offset."""
        text = self.text
        position = tag.end
        if text[tag.start : tag.end].endswith("/>"):
            return DecodedText("", (), tag.end)
        chars: list[str] = []
        offsets: list[int] = []
        while position < len(text):
            if text.startswith("<!--", position):
                close = text.find("-->", position)
                position = len(text) if close < 0 else close + 3
                continue
            if text.startswith("<![CDATA[", position):
                close = text.find("]]>", position)
                body_end = len(text) if close < 0 else close
                for index in range(position + 9, body_end):
                    chars.append(text[index])
                    offsets.append(index)
                position = body_end + 3
                continue
            char = text[position]
            if char == "<":
                break
            if char == "&":
                entity = _ENTITY.match(text, position)
                if entity:
                    chars.append(_decode_entity(entity.group(1)))
                    offsets.append(position)
                    position = entity.end()
                    continue
            if char == "\r":
                position += 1  # XML normalises line ends; keep offsets of the other chars
                continue
            chars.append(char)
            offsets.append(position)
            position += 1
        return DecodedText("".join(chars), tuple(offsets), position)


def _decode_entity(name: str) -> str:
    if name.startswith("#x"):
        return chr(int(name[2:], 16))
    if name.startswith("#"):
        return chr(int(name[1:]))
    return _NAMED.get(name, "?")
