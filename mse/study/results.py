"""The results CSV: one row per answer, the columns of :data:`RESULT_COLUMNS`
(docs/study.md).  The server checks every upload against the study's manifest before
keeping it, so that a results folder holds only well-formed answers."""

from __future__ import annotations

import csv
import io
import math
import re
from typing import Any

from mse.study.design import RESULT_COLUMNS

#: A participant id as a file name: letters, digits, ``-`` and ``_``.
PARTICIPANT_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")


class BadResults(ValueError):
    """An upload that is not a results CSV of this study (the message says why)."""


def check_results(text: str, participant: str, manifest: dict[str, Any]) -> int:
    """The number of answers in ``text``; BadResults when it is not this participant's
    results CSV of this study."""
    stimuli = {s["id"]: s for s in manifest["stimuli"]}
    labels = set(manifest["labels"])
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        header = next(reader, None)
        if header is None or tuple(header) != RESULT_COLUMNS:
            raise BadResults(f"the first line must be the header {','.join(RESULT_COLUMNS)}")
        count = 0
        for number, row in enumerate(reader, start=2):
            if not row:
                continue
            _check_row(row, number, participant, stimuli, labels)
            count += 1
    except csv.Error as error:
        raise BadResults(f"not CSV: {error}") from None
    return count


def _check_row(row: list[str], number: int, participant: str, stimuli: dict[str, Any], labels: set[str]) -> None:
    def bad(message: str) -> BadResults:
        return BadResults(f"line {number}: {message}")

    if len(row) != len(RESULT_COLUMNS):
        raise bad(f"{len(row)} fields, expected {len(RESULT_COLUMNS)}")
    values = dict(zip(RESULT_COLUMNS, row, strict=True))
    if values["participant"] != participant:
        raise bad(f"participant {values['participant']!r} is not {participant!r}")
    ids = values["stimulus"].split("|")
    if any(i not in stimuli for i in ids):
        raise bad(f"unknown stimulus {values['stimulus']!r}")
    shown = [stimuli[i] for i in ids]
    if any(s["emotion"] != values["emotion"] for s in shown):
        raise bad(f"emotion {values['emotion']!r} does not match stimulus {values['stimulus']!r}")
    if values["condition"] != "|".join(s["condition"] for s in shown):
        raise bad(f"condition {values['condition']!r} does not match stimulus {values['stimulus']!r}")
    if values["task"] == "label":
        if len(ids) != 1 or values["response"] not in labels:
            raise bad(f"label answer {values['response']!r} is not one of {', '.join(sorted(labels))}")
    elif values["task"] == "pair":
        if len(ids) != 2 or values["response"] not in values["condition"].split("|"):
            raise bad(f"pair answer {values['response']!r} is not one of the conditions shown")
    else:
        raise bad(f"task {values['task']!r} is not label or pair")
    if not values["trial"].isdigit() or int(values["trial"]) < 1:
        raise bad(f"trial {values['trial']!r} is not a positive whole number")
    try:
        seconds = float(values["seconds"])
    except ValueError:
        seconds = math.nan
    if not (math.isfinite(seconds) and seconds >= 0):
        raise bad(f"seconds {values['seconds']!r} is not a time")
