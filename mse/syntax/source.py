"""Positions in the raw text of an XML file.

lxml tells the line of an element but not its column, nor where an attribute or a
character of text content sits.  :class:`SourceText` scans the raw text once to find every
start tag (in document order, skipping comments, CDATA, processing instructions and the
DOCTYPE), so that element *k* of the parsed tree pairs with start tag *k*; it then maps
attribute names and decoded text offsets (entities, CDATA, line ends) back to ``line:col``.

The scan runs only on a document lxml has already parsed, and it is linear: every step
finds its terminator with ``str.find`` (an unclosed ``<!--`` skips to the end once), and no
regular expression can backtrack more than a bounded amount.  The scan never decides what
the document *says* (the parsed tree does); a mismatch only makes positions coarser.
"""

from __future__ import annotations

import bisect
import re
from dataclasses import dataclass

from mse.diagnostics import Span

_START_TAG = re.compile(r"<([^\s/>!?][^\s/>]{0,1000})")
_DOCTYPE_TOKEN = re.compile(r"[\"'\[\]>]|<!--|<\?")
_TAG_TOKEN = re.compile(r"[\"'>]")
_ENTITY = re.compile(r"&(#x[0-9A-Fa-f]{1,32}|#[0-9]{1,32}|[^\s;&<#]{1,100});")
_NAMED = {"lt": "<", "gt": ">", "amp": "&", "quot": '"', "apos": "'"}
_UNKNOWN_ENTITY = re.compile(r"&(?!(?:lt|gt|amp|quot|apos|#[0-9]{1,32}|#x[0-9A-Fa-f]{1,32});)")
_SPACE = " \t\r\n"


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
        self._line_starts = [0]
        position = text.find("\n")
        while position >= 0:
            self._line_starts.append(position + 1)
            position = text.find("\n", position + 1)
        #: Offset of the first reference to an entity other than the five predefined ones.
        self.unknown_entities: list[int] = []
        self.start_tags = self._scan_start_tags()

    def span_at(self, offset: int) -> Span:
        line_index = bisect.bisect_right(self._line_starts, offset) - 1
        return Span(self.path, line_index + 1, offset - self._line_starts[line_index] + 1)

    def line_span(self, line: int) -> Span:
        """Column of the first non-blank character of ``line`` (1-based)."""
        if not 1 <= line <= len(self._line_starts):
            return Span(self.path, max(line, 0), 1 if line > 0 else 0)
        start = self._line_starts[line - 1]
        end = self._line_starts[line] if line < len(self._line_starts) else len(self.text)
        segment = self.text[start:end]
        return Span(self.path, line, len(segment) - len(segment.lstrip(" \t")) + 1)

    def find(self, needle: str) -> Span | None:
        offset = self.text.find(needle)
        return self.span_at(offset) if offset >= 0 else None

    # -- the scan -------------------------------------------------------------------------
    def _skip_to(self, terminator: str, start: int) -> int:
        close = self.text.find(terminator, start)
        return len(self.text) if close < 0 else close + len(terminator)

    def _doctype_end(self, position: int) -> int:
        """Offset after the '>' closing a DOCTYPE (its internal subset may hold quoted
        strings, comments and processing instructions containing '>' or ']')."""
        text = self.text
        in_subset = False
        while True:
            token = _DOCTYPE_TOKEN.search(text, position)
            if token is None:
                return len(text)
            found = token.group()
            if found in "\"'":
                position = self._skip_to(found, token.end())
            elif found == "<!--":
                position = self._skip_to("-->", token.end())
            elif found == "<?":
                position = self._skip_to("?>", token.end())
            else:
                position = token.end()
                if found == "[":
                    in_subset = True
                elif found == "]":
                    in_subset = False
                elif not in_subset:  # '>'
                    return position

    def _tag_end(self, position: int) -> int:
        """Offset after the '>' closing a start tag (quoted values may hold '>')."""
        text = self.text
        while True:
            token = _TAG_TOKEN.search(text, position)
            if token is None:
                return len(text)
            if token.group() == ">":
                return token.end()
            position = self._skip_to(token.group(), token.end())

    def _note_entities(self, start: int, end: int) -> None:
        """Record the first reference to an entity that is not predefined (one search in C)."""
        if not self.unknown_entities:
            found = _UNKNOWN_ENTITY.search(self.text, start, end)
            if found is not None:
                self.unknown_entities.append(found.start())

    def _scan_start_tags(self) -> list[StartTag]:
        tags: list[StartTag] = []
        position = 0
        text = self.text
        while True:
            lt = text.find("<", position)
            self._note_entities(position, len(text) if lt < 0 else lt)
            if lt < 0:
                return tags
            if text.startswith("<!--", lt):
                position = self._skip_to("-->", lt + 4)
            elif text.startswith("<![CDATA[", lt):
                position = self._skip_to("]]>", lt + 9)
            elif text.startswith("<?", lt):
                position = self._skip_to("?>", lt + 2)
            elif text.startswith("<!DOCTYPE", lt):
                position = self._doctype_end(lt + 9)
            elif text.startswith("</", lt) or text.startswith("<!", lt):
                position = self._skip_to(">", lt + 2)
            else:
                match = _START_TAG.match(text, lt)
                if match is None:
                    position = lt + 1
                    continue
                end = self._tag_end(match.end())
                self._note_entities(match.end(), end)
                tags.append(StartTag(match.group(1), lt, end))
                position = end

    # -- attributes and text content --------------------------------------------------------
    def attribute_spans(self, tag: StartTag) -> dict[str, Span]:
        """Where each attribute name of a (well-formed) start tag begins."""
        spans: dict[str, Span] = {}
        text = self.text
        position = tag.start + 1 + len(tag.name)
        stop = tag.end
        while position < stop:
            while position < stop and text[position] in _SPACE:
                position += 1
            equals = text.find("=", position, stop)
            if equals < 0:
                break
            name = text[position:equals].strip(_SPACE)
            spans.setdefault(name, self.span_at(position))
            value = equals + 1
            while value < stop and text[value] in _SPACE:
                value += 1
            if value >= stop or text[value] not in "\"'":
                break
            close = text.find(text[value], value + 1, stop)
            if close < 0:
                break
            position = close + 1
        return spans

    def decode_content(self, tag: StartTag) -> DecodedText:
        """Decode the character data after ``tag`` up to its end tag or first child element
        (comments and processing instructions skipped, CDATA and references decoded, line
        ends normalised as XML does), keeping each character's raw offset."""
        text = self.text
        position = tag.end
        if text[tag.start : tag.end].endswith("/>"):
            return DecodedText("", (), tag.end)
        chars: list[str] = []
        offsets: list[int] = []
        length = len(text)
        while position < length:
            char = text[position]
            if char == "<":
                if text.startswith("<!--", position):
                    position = self._skip_to("-->", position + 4)
                    continue
                if text.startswith("<?", position):
                    position = self._skip_to("?>", position + 2)
                    continue
                if text.startswith("<![CDATA[", position):
                    close = text.find("]]>", position + 9)
                    body_end = length if close < 0 else close
                    index = position + 9
                    while index < body_end:
                        index = self._append(chars, offsets, index)
                    position = body_end + 3
                    continue
                break
            if char == "&":
                entity = _ENTITY.match(text, position)
                if entity:
                    chars.append(_decode_entity(entity.group(1)))
                    offsets.append(position)
                    position = entity.end()
                    continue
            position = self._append(chars, offsets, position)
        return DecodedText("".join(chars), tuple(offsets), min(position, length))

    def _append(self, chars: list[str], offsets: list[int], position: int) -> int:
        """Append the character at ``position`` with XML's line-end handling (CR LF and a
        lone CR read as LF); returns the next position."""
        text = self.text
        char = text[position]
        if char == "\r":
            offsets.append(position)
            chars.append("\n")
            return position + 2 if text.startswith("\r\n", position) else position + 1
        chars.append(char)
        offsets.append(position)
        return position + 1


def _decode_entity(name: str) -> str:
    try:
        if name.startswith("#x"):
            return chr(int(name[2:], 16))
        if name.startswith("#"):
            return chr(int(name[1:]))
    except (ValueError, OverflowError):
        return "\ufffd"
    return _NAMED.get(name, "\ufffd")
