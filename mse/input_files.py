"""Reading input files: regular files only (or ``-`` for standard input), never more than a
size limit, so ``/dev/zero``, a FIFO without a writer or a 300 MB stdin cannot grow memory or
hang; bad bytes, deep nesting, huge integers and NaN/Infinity become located diagnostics.

Writing (atomic files, staged folders, the cache folder) is :mod:`mse.fileio`'s.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import stat
import sys
from collections.abc import Iterator
from typing import Any, BinaryIO

from mse.diagnostics import Diagnostic, MseError, Span
from mse.limits import MAX_INPUT_BYTES, MAX_JSON_DEPTH, MAX_JSON_INT_DIGITS

PathLike = str | os.PathLike[str]


def located_error(code: str, message: str, path: str, line: int = 0, col: int = 0) -> MseError:
    return MseError([Diagnostic(code, message, Span(path, line, col))])


def file_kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISFIFO(mode):
        return "a FIFO"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def read_capped(stream: BinaryIO, limit: int, name: str) -> bytes:
    """At most ``limit`` bytes from ``stream``; E104 when it holds more."""
    data = stream.read(limit + 1)
    if len(data) > limit:
        raise located_error("E104", f"input is larger than the limit of {limit} bytes", name)
    return data


#: (device, inode) of every file read while :func:`recording_reads` is active: a command's
#: outputs must never replace one of them (mse.fileio), including the files a folder
#: argument expanded to, which no list of command-line paths names.
_FILES_READ: set[tuple[int, int]] | None = None


@contextlib.contextmanager
def recording_reads() -> Iterator[None]:
    """Within this block (one command), remember every file :func:`read_input` reads."""
    global _FILES_READ
    previous = _FILES_READ
    _FILES_READ = set()
    try:
        yield
    finally:
        _FILES_READ = previous


def was_read(info: os.stat_result) -> bool:
    """True when the file ``info`` describes was read within :func:`recording_reads`."""
    return _FILES_READ is not None and (info.st_dev, info.st_ino) in _FILES_READ


def note_read(path: PathLike) -> None:
    """Record ``path`` as read (for readers that do not go through :func:`read_input`)."""
    if _FILES_READ is not None:
        with contextlib.suppress(OSError, ValueError):
            info = os.stat(os.fspath(path))
            _FILES_READ.add((info.st_dev, info.st_ino))


def read_stdin(limit: int = MAX_INPUT_BYTES) -> bytes:
    """Standard input, at most ``limit`` bytes; closed or unreadable -> E100, larger -> E104."""
    try:
        return read_capped(sys.stdin.buffer, limit, "<stdin>")
    except (OSError, AttributeError, ValueError) as error:  # started without stdin (<&-)
        reason = error.strerror if isinstance(error, OSError) and error.strerror else "it is closed"
        raise located_error("E100", f"cannot read standard input: {reason}", "<stdin>") from None


def read_input(path: PathLike, *, limit: int = MAX_INPUT_BYTES, what: str = "file", record: bool = True) -> bytes:
    """The bytes of the regular file ``path`` (``-``: standard input), at most ``limit``.

    Missing, unreadable, non-regular (devices, FIFOs, directories) -> E100; larger than the
    limit -> E104.  Never blocks on a FIFO and never reads more than ``limit + 1`` bytes.
    ``record``: remember the file as an input of the command (off for cache entries, which
    are rewritten when stale)."""
    name = os.fspath(path)
    if name == "-":
        return read_stdin(limit)
    try:
        # O_NONBLOCK: opening a FIFO without a writer must not hang (it is refused below).
        fd = os.open(name, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as error:
        raise located_error("E100", f"cannot read {what}: {error.strerror or error}", name) from None
    except ValueError:  # a NUL character in the name
        raise located_error("E100", f"cannot read {what}: the name holds a NUL character", repr(name)) from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            hint = "" if stat.S_ISDIR(info.st_mode) else "; give a regular file, or '-' for standard input"
            raise located_error("E100", f"cannot read {what}: is {file_kind(info.st_mode)}{hint}", name)
        if info.st_size > limit:
            raise located_error("E104", f"{what} is {info.st_size} bytes; the limit is {limit}", name)
        if record and _FILES_READ is not None:
            _FILES_READ.add((info.st_dev, info.st_ino))
        chunks: list[bytes] = []
        total = 0
        while total <= limit:
            chunk = os.read(fd, min(1 << 20, limit + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        if total > limit:  # the file grew while it was read
            raise located_error("E104", f"{what} is larger than the limit of {limit} bytes", name)
        return b"".join(chunks)
    except OSError as error:
        raise located_error("E100", f"cannot read {what}: {error.strerror or error}", name) from None
    finally:
        os.close(fd)


def decode_utf8(data: bytes, name: str, *, code: str = "E100", what: str = "file") -> str:
    """``data`` as UTF-8 text (a leading BOM dropped); bad bytes -> ``code`` at line:col."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        start = error.start
        line = data.count(b"\n", 0, start) + 1
        col = start - (data.rfind(b"\n", 0, start) + 1) + 1
        raise located_error(code, f"{what} is not valid UTF-8 (byte 0x{data[start]:02x})", name, line, col) from None
    return text[1:] if text.startswith("\ufeff") else text


class _JsonLimit(ValueError):
    pass


def _json_int(text: str) -> int:
    if len(text.lstrip("-")) > MAX_JSON_INT_DIGITS:
        raise _JsonLimit(f"an integer of {len(text.lstrip('-'))} digits (the limit is {MAX_JSON_INT_DIGITS})")
    return int(text)


def _json_float(text: str) -> float:
    value = float(text)
    if value in (float("inf"), float("-inf")):
        raise _JsonLimit(f"the number {text[:40]} is out of range")
    return value


def _json_constant(text: str) -> Any:
    raise _JsonLimit(f"{text} is not a JSON number")


_SURROGATE = re.compile("[\ud800-\udfff]")


def json_depth(obj: Any) -> int:
    """Nesting depth of decoded JSON (scalars 0), without recursion; -1 when a string or a
    key holds a lone surrogate (``"\\ud800"`` decodes to text no file can hold)."""
    deepest = 0
    stack: list[tuple[Any, int]] = [(obj, 0)]
    while stack:
        node, depth = stack.pop()
        if isinstance(node, str):
            if _SURROGATE.search(node):
                return -1
            continue
        if isinstance(node, dict):
            if any(_SURROGATE.search(key) for key in node):
                return -1
            node = list(node.values())
        if isinstance(node, list):
            depth += 1
            deepest = max(deepest, depth)
            if depth > MAX_JSON_DEPTH:
                return depth
            stack.extend((child, depth) for child in node if isinstance(child, dict | list | str))
    return deepest


_JSON_TOKEN = re.compile(r'"(?:[^"\\]|\\.)*"|-?[0-9]+(?:\.[0-9]+)?(?:[eE][+-]?[0-9]+)?|NaN|-?Infinity|[\[\]{}]')


def _json_problem_at(text: str) -> tuple[int, int]:
    """Line and column of the first token that breaks a limit of :func:`parse_json` (too
    deep, a huge or infinite number, NaN, a string with a lone surrogate); linear, and only
    run once decoding has already failed.  (1, 1) when nothing is found."""
    depth = 0
    for token in _JSON_TOKEN.finditer(text):
        found = token.group()
        bad = False
        if found in "[{":
            depth += 1
            bad = depth > MAX_JSON_DEPTH
        elif found in "]}":
            depth -= 1
        elif found.startswith('"'):
            with contextlib.suppress(ValueError):
                bad = "\\u" in found and _SURROGATE.search(json.loads(found)) is not None
        else:
            digits = found.lstrip("-").split(".")[0].split("e")[0].split("E")[0]
            bad = found in ("NaN", "Infinity", "-Infinity") or len(digits) > MAX_JSON_INT_DIGITS
            bad = bad or float(found) in (float("inf"), float("-inf"))
        if bad:
            line = text.count("\n", 0, token.start()) + 1
            return line, token.start() - (text.rfind("\n", 0, token.start()) + 1) + 1
    return 1, 1


def parse_json(text: str, name: str, *, code: str = "E100", line: int | None = None) -> Any:
    """Decode JSON text; syntax errors, nesting deeper than MAX_JSON_DEPTH, integers of
    more than MAX_JSON_INT_DIGITS digits, NaN/Infinity and strings holding a lone surrogate
    -> ``code`` at the offending line:col.
    ``line``: the 1-based line of ``text`` in its file (one line of a JSON-lines file)."""
    first = line or 1

    def fail(message: str) -> MseError:
        at_line, col = _json_problem_at(text)
        return located_error(code, message, name, at_line + first - 1, col)

    try:
        obj = json.loads(text, parse_int=_json_int, parse_float=_json_float, parse_constant=_json_constant)
    except json.JSONDecodeError as error:
        raise located_error(code, f"invalid JSON: {error.msg}", name, error.lineno + first - 1, error.colno) from None
    except RecursionError:
        raise fail(f"JSON nested more than {MAX_JSON_DEPTH} levels deep") from None
    except ValueError as error:  # _JsonLimit, and any other limit of the json module
        raise fail(f"invalid JSON: {error}") from None
    depth = json_depth(obj)
    if depth < 0:
        raise fail("invalid JSON: a string holds a lone surrogate (not a Unicode character)")
    if depth > MAX_JSON_DEPTH:
        raise fail(f"JSON nested more than {MAX_JSON_DEPTH} levels deep")
    return obj


def read_json(path: PathLike, *, limit: int = MAX_INPUT_BYTES, what: str = "file", code: str = "E100") -> Any:
    """A JSON file read with :func:`read_input`, :func:`decode_utf8` and :func:`parse_json`."""
    name = os.fspath(path)
    text = decode_utf8(read_input(path, limit=limit, what=what), name, code=code, what=what)
    return parse_json(text, name, code=code)


def parse_toml(text: str, name: str, *, code: str = "E100", what: str = "TOML file") -> dict[str, Any]:
    """The tables of ``text``; invalid TOML or nesting too deep for the parser -> ``code``."""
    import tomllib

    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise located_error(code, f"{what} is not valid TOML: {error}", name) from None
    except RecursionError:
        raise located_error(code, f"{what} nests arrays or tables too deeply", name) from None
