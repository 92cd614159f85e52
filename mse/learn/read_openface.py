"""OpenFace 2.0 CSV (FeatureExtraction's output) as a learning corpus: each action unit's presence
column (``AUxx_c``) becomes occurrences of the signal ``AUxx`` on the ``face`` tier, one per run of
consecutive frames where the unit is present (value >= 0.5), from the run's first frame's
``timestamp`` to the next frame's.  Rows with ``success`` 0 (no face found) end every run; one
sequence per ``face_id``.  Fields may be separated by ``", "`` (OpenFace) or ``","``.
"""

from __future__ import annotations

import csv
import io
import math
import re
from pathlib import Path

from mse.diagnostics import Diagnostic, Span
from mse.learn.corpus import Annotation, RawSequence

_PRESENCE = re.compile(r"^AU(\d+)_c$")
TIER = "face"


def is_openface_header(cells: list[str]) -> bool:
    """An OpenFace 2.0 header: ``timestamp`` and at least one ``AUxx_c`` column."""
    names = {cell.strip() for cell in cells}
    return "timestamp" in names and any(_PRESENCE.match(name) for name in names)


def read_openface(path: str | Path, text: str) -> tuple[list[RawSequence], list[Diagnostic]]:
    name = str(path)
    rows = csv.reader(io.StringIO(text, newline=""), skipinitialspace=True)
    header = [cell.strip() for cell in next(rows, [])]
    column = {cell: index for index, cell in enumerate(header)}
    units = [(int(m.group(1)), column[cell]) for cell in header if (m := _PRESENCE.match(cell))]
    found: list[Diagnostic] = []
    frames: dict[str, list[tuple[float, bool, list[bool], int]]] = {}
    for row in rows:
        line = rows.line_num
        if not row or all(not cell.strip() for cell in row):
            continue
        span = Span(name, line, 1)
        if len(row) != len(header):
            found.append(Diagnostic("E121", f"row has {len(row)} fields; the header has {len(header)}", span))
            continue
        try:
            time = float(row[column["timestamp"]])
            success = float(row[column["success"]]) >= 0.5 if "success" in column else True
            present = [float(row[index]) >= 0.5 for _, index in units]
        except ValueError as error:
            found.append(Diagnostic("E121", f"not a number: {error}", span))
            continue
        if not math.isfinite(time) or not 0 <= time < 1e7:
            found.append(Diagnostic("E121", f"timestamp must be between 0 and 10^7 seconds, not {time}", span))
            continue
        face = row[column["face_id"]].strip() if "face_id" in column else "0"
        frames.setdefault(face, []).append((time, success, present, line))
    if any(d.is_error for d in found):
        return [], found
    sequences = []
    stem = Path(name).stem
    for face, rows_of_face in frames.items():
        rows_of_face.sort(key=lambda r: r[0])
        if len(rows_of_face) < 2:
            continue
        step = (rows_of_face[-1][0] - rows_of_face[0][0]) / (len(rows_of_face) - 1)
        ends = [r[0] for r in rows_of_face[1:]] + [rows_of_face[-1][0] + step]
        annotations: list[Annotation] = []
        for u, (number, _) in enumerate(units):
            begin: tuple[float, int] | None = None
            for (time, success, present, line), end in zip(rows_of_face, ends, strict=True):
                on = success and present[u]
                if on and begin is None:
                    begin = (time, line)
                if begin is not None and (not on or end == ends[-1]):
                    stop = end if on else time
                    start_ms, stop_ms = round(begin[0] * 1000), round(stop * 1000)
                    if stop_ms > start_ms:
                        annotations.append(
                            Annotation(
                                TIER,
                                f"AU{number}",
                                start_ms,
                                stop_ms,
                                Span(name, begin[1], 1),
                                lexeme=f"AU{number}",
                                modality="face",
                            )
                        )
                    begin = None
        label = stem if len(frames) == 1 else f"{stem}#face{face}"
        duration = round(ends[-1] * 1000)
        sequences.append(RawSequence(label, tuple(annotations), Span(name, rows_of_face[0][3], 1), duration))
    return sequences, found
