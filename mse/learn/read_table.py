"""CSV and TSV corpora: one annotation per row, ``sequence, tier, start, stop, label``
(an OpenFace 2.0 CSV, told by its header, is read by :mod:`mse.learn.read_openface`).

Times are seconds.  A first row naming the columns (``sequence``, ``tier``, ``start``,
``stop``, ``label``, in any order, optionally ``duration``: the sequence's length in seconds)
is a header; without one the five columns come in that order.  ``.tsv`` and ``.tab`` files
are tab-separated, other files comma-separated.  Every bad row is reported with its line.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from mse.diagnostics import Diagnostic, Span
from mse.learn.corpus import Annotation, RawSequence
from mse.limits import parse_double
from mse.syntax.reader import decode_text, read_bytes

COLUMNS = ("sequence", "tier", "start", "stop", "label")


def read_table(path: str | Path, data: bytes | None = None) -> tuple[list[RawSequence], list[Diagnostic]]:
    """The sequences of one CSV/TSV file (in order of first appearance)."""
    name = str(path)
    if data is None:
        data, problems = read_bytes(path)
        if data is None:
            return [], problems
    delimiter = "\t" if Path(name).suffix.lower() in (".tsv", ".tab") else ","
    from mse.learn.read_openface import is_openface_header, read_openface

    text = decode_text(data)
    if delimiter == "," and is_openface_header(text.split("\n", 1)[0].split(",")):
        return read_openface(name, text)
    rows = csv.reader(io.StringIO(text, newline=""), delimiter=delimiter)
    found: list[Diagnostic] = []
    order: dict[str, list[Annotation]] = {}
    durations: dict[str, int] = {}
    first_line: dict[str, int] = {}
    columns: dict[str, int] | None = None
    try:
        for row in rows:
            line = rows.line_num
            if not row or all(not cell.strip() for cell in row) or row[0].lstrip().startswith("#"):
                continue
            cells = [cell.strip() for cell in row]
            if columns is None:
                header = {cell.lower(): index for index, cell in enumerate(cells)}
                if set(COLUMNS) <= set(header):
                    columns = header
                    continue
                columns = {column: index for index, column in enumerate(COLUMNS)}
            _row(cells, columns, Span(name, line, 1), order, durations, first_line, found)
    except csv.Error as error:
        found.append(Diagnostic("E120", f"not a readable {'TSV' if delimiter == chr(9) else 'CSV'} file: {error}",
                                Span(name, rows.line_num, 1)))
    if any(d.is_error for d in found):
        return [], found
    sequences = [
        RawSequence(key, tuple(annotations), Span(name, first_line[key], 1), durations.get(key))
        for key, annotations in order.items()
    ]
    for sequence in sequences:
        late = [a for a in sequence.annotations if sequence.duration is not None and a.stop > sequence.duration]
        if late:
            found.append(Diagnostic("E121", f"annotation ends after the duration of sequence {sequence.name!r}",
                                    late[0].span))
    return sequences, found


def _row(
    cells: list[str],
    columns: dict[str, int],
    span: Span,
    order: dict[str, list[Annotation]],
    durations: dict[str, int],
    first_line: dict[str, int],
    found: list[Diagnostic],
) -> None:
    needed = max(columns[c] for c in COLUMNS) + 1
    if len(cells) < needed:
        found.append(Diagnostic("E121", f"row has {len(cells)} columns; expected {', '.join(COLUMNS)}", span))
        return
    sequence, tier, label = (cells[columns[c]] for c in ("sequence", "tier", "label"))
    start = _seconds(cells[columns["start"]], "start", span, found)
    stop = _seconds(cells[columns["stop"]], "stop", span, found)
    if start is None or stop is None:
        return
    if not sequence or not tier:
        found.append(Diagnostic("E121", "sequence and tier must not be empty", span))
        return
    if stop <= start:
        found.append(Diagnostic("E121", f"stop ({stop / 1000:g} s) must be after start ({start / 1000:g} s)", span))
        return
    if "duration" in columns and columns["duration"] < len(cells) and cells[columns["duration"]]:
        duration = _seconds(cells[columns["duration"]], "duration", span, found)
        if duration is not None:
            if duration <= 0 or durations.get(sequence, duration) != duration:
                found.append(Diagnostic("E121", f"duration of sequence {sequence!r} must be positive and the "
                                        "same on every row", span))
                return
            durations[sequence] = duration
    first_line.setdefault(sequence, span.line)
    order.setdefault(sequence, []).append(Annotation(tier, label, start, stop, span))


def _seconds(text: str, what: str, span: Span, found: list[Diagnostic]) -> int | None:
    value = parse_double(text)  # ASCII digits only (float() also takes "1_0" and other scripts' digits)
    if value is None:
        found.append(Diagnostic("E121", f"{what} must be a number of seconds in ASCII digits, not {text[:40]!r}",
                                span))
        return None
    if not math.isfinite(value) or not 0 <= value < 1e7:
        found.append(Diagnostic("E121", f"{what} must be between 0 and 10^7 seconds, not {text[:40]!r}", span))
        return None
    return round(value * 1000)
