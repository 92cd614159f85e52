"""The server's check of an uploaded results CSV (docs/study.md): the one reader of results
tables (:func:`mse.study.analysis.results.parse_results`, what ``mse study analyze`` reads)
plus what only the study's manifest can say: the page's exact header, this participant,
known stimuli of the right emotion and condition, labels of the study.  A results folder
so holds only answers ``mse study analyze`` reads."""

from __future__ import annotations

import re
from typing import Any

from mse.study.analysis.results import Answer, parse_results
from mse.study.design import RESULT_COLUMNS

#: A participant id as a file name: letters, digits, ``-`` and ``_``.
PARTICIPANT_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")


class BadResults(ValueError):
    """An upload that is not a results CSV of this study (the message says why)."""


def check_results(text: str, participant: str, manifest: dict[str, Any]) -> int:
    """The number of answers in ``text``; BadResults when it is not this participant's
    results CSV of this study."""
    first = text.split("\n", 1)[0].removesuffix("\r")
    if first != ",".join(RESULT_COLUMNS):
        raise BadResults(f"the first line must be the header {','.join(RESULT_COLUMNS)}")
    answers, problems = parse_results(text, "upload")
    if problems:
        problem = problems[0]
        raise BadResults(f"line {problem.span.line}: {problem.message}" if problem.span.line else problem.message)
    stimuli = {s["id"]: s for s in manifest["stimuli"]}
    labels = set(manifest["labels"])
    for answer in answers:
        _check_answer(answer, participant, stimuli, labels)
    return len(answers)


def _check_answer(answer: Answer, participant: str, stimuli: dict[str, Any], labels: set[str]) -> None:
    def bad(message: str) -> BadResults:
        return BadResults(f"line {answer.span.line}: {message}")

    if answer.participant != participant:
        raise bad(f"participant {answer.participant!r} is not {participant!r}")
    ids = answer.stimulus.split("|")
    if any(i not in stimuli for i in ids):
        raise bad(f"unknown stimulus {answer.stimulus!r}")
    shown = [stimuli[i] for i in ids]
    if any(s["emotion"] != answer.emotion for s in shown):
        raise bad(f"emotion {answer.emotion!r} does not match stimulus {answer.stimulus!r}")
    if answer.conditions != tuple(s["condition"] for s in shown):
        raise bad(f"condition {answer.condition!r} does not match stimulus {answer.stimulus!r}")
    if answer.task == "label" and answer.response not in labels:
        raise bad(f"label answer {answer.response!r} is not one of {', '.join(sorted(labels))}")
    if answer.trial is None or answer.trial < 1:
        raise bad("trial must be a positive whole number")
    if answer.seconds is None:
        raise bad("seconds must be a time")
