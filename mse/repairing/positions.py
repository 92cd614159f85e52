"""Where each value of a JSON document starts (line and column), so that a problem found
after decoding (a negative time, an unknown key) is reported at its place in the file.

Python's ``json`` keeps no positions.  The document has already been decoded by
:func:`mse.fileio.parse_json` (so it is valid JSON within mse's limits); this scanner walks
the same text once more, iteratively, and records the position of every value whose path
(keys and indices from the root) is at most ``depth`` deep.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

#: A path from the root: object keys and array indices.
Path = tuple[str | int, ...]

_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.DOTALL)
_SCALAR = re.compile(r"-?[0-9][0-9.eE+-]*|true|false|null")
_SPACE = re.compile(r"[ \t\r\n]*")


@dataclass(frozen=True, slots=True)
class Positions:
    """line:col (1-based) of the values of a JSON text, by path."""

    at: dict[Path, tuple[int, int]]

    def of(self, path: Path) -> tuple[int, int]:
        """The position of the value at ``path``, else of its nearest recorded parent."""
        while path not in self.at and path:
            path = path[:-1]
        return self.at.get(path, (1, 1))


@dataclass(slots=True)
class _Open:
    """An open container: its path, its kind, the next index (arrays), the pending key (objects)."""

    path: Path
    is_object: bool
    index: int = 0
    key: str | None = None


def json_positions(text: str, depth: int = 4) -> Positions:
    """Positions of the values of ``text`` (valid JSON) down to ``depth`` levels."""
    import json

    line_starts = [0] + [m.end() for m in re.finditer("\n", text)]

    def where(offset: int) -> tuple[int, int]:
        low, high = 0, len(line_starts) - 1
        while low < high:  # the last line start <= offset
            middle = (low + high + 1) // 2
            if line_starts[middle] <= offset:
                low = middle
            else:
                high = middle - 1
        return low + 1, offset - line_starts[low] + 1

    found: dict[Path, tuple[int, int]] = {}
    stack: list[_Open] = []
    offset = _SPACE.match(text, 0).end()  # type: ignore[union-attr]
    while offset < len(text):
        char = text[offset]
        if char in " \t\r\n,:":
            offset = _SPACE.match(text, offset + 1).end()  # type: ignore[union-attr]
            continue
        if stack and stack[-1].is_object and stack[-1].key is None and char == '"':
            key = _STRING.match(text, offset)
            assert key is not None
            stack[-1].key = json.loads(key.group())
            offset = key.end()
            continue
        if char in "]}":
            stack.pop()
            offset += 1
            continue
        # A value starts here: its path is the parent's plus the key or index.
        if stack:
            parent = stack[-1]
            if parent.is_object:
                step: str | int = str(parent.key)
                parent.key = None
            else:
                step = parent.index
                parent.index += 1
            path: Path = (*parent.path, step)
        else:
            path = ()
        if len(path) <= depth:
            found[path] = where(offset)
        if char in "[{":
            stack.append(_Open(path, char == "{"))
            offset += 1
            continue
        token = _STRING.match(text, offset) if char == '"' else _SCALAR.match(text, offset)
        offset = token.end() if token is not None else offset + 1
    return Positions(found)
