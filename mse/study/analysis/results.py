"""The results table of a perception study: one CSV row per answer (docs/study-analysis.md).

Header (any order; ``stimulus``, ``trial`` and ``seconds`` may be left out or empty, other
columns are ignored)::

    participant,task,emotion,condition,response,stimulus,trial,seconds

``task`` is ``label`` (a forced-choice label for one stimulus: ``condition`` is the stimulus'
condition, ``response`` the label chosen) or ``pair`` (a believability choice between two
stimuli of one emotion: ``condition`` is ``A|B`` in the order shown, left then right, and
``response`` the condition chosen).  Every bad cell is reported as ``path:line:col: E171``;
a file that is no such table as ``E170``.
"""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from mse.diagnostics import Diagnostic, MseError, Span
from mse.input_files import decode_utf8, read_input
from mse.limits import MAX_NAME_CHARS, MAX_STUDY_ANSWERS, MAX_STUDY_CONDITIONS, MAX_STUDY_LABELS, MAX_STUDY_STIMULI

REQUIRED = ("participant", "task", "emotion", "condition", "response")
OPTIONAL = ("stimulus", "trial", "seconds")
TASKS = ("label", "pair")
#: The condition a believability pair compares against the other (``share`` = fraction choosing it).
MSE_CONDITION = "mse"
#: Emotions, conditions and labels: names that can go into a file name and a Markdown table.
NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.\-]*\Z")
_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


@dataclass(frozen=True, slots=True)
class Answer:
    """One answer of one participant."""

    participant: str
    task: str
    emotion: str
    #: ``label``: the stimulus' condition; ``pair``: the two conditions shown, left then right.
    conditions: tuple[str, ...]
    response: str
    stimulus: str
    trial: int | None
    seconds: float | None
    span: Span

    @property
    def condition(self) -> str:
        """The condition of a label answer's stimulus (``A|B`` for a pair)."""
        return "|".join(self.conditions)


def results_files(paths: Iterable[str]) -> list[str]:
    """The CSV files to read: each path itself, or a folder's ``*.csv`` files (sorted, not recursive)."""
    files: list[str] = []
    for path in paths:
        if path != "-" and os.path.isdir(path):
            inside = sorted(str(p) for p in Path(path).glob("*.csv") if p.is_file())
            if not inside:
                raise MseError([Diagnostic("E170", "no results (*.csv) in this folder", Span(path))])
            files.extend(inside)
        else:
            files.append(path)
    return files


def read_results(paths: Sequence[str]) -> tuple[Answer, ...]:
    """Every answer of the files (folders: their ``*.csv``); MseError with every problem found."""
    answers: list[Answer] = []
    problems: list[Diagnostic] = []
    for path in results_files(paths):
        text = decode_utf8(read_input(path, what="results file"), path, code="E170", what="results file")
        found, file_problems = parse_results(text, path)
        answers.extend(found)
        problems.extend(file_problems)
        if len(answers) > MAX_STUDY_ANSWERS:
            raise MseError([Diagnostic("E170", f"more than {MAX_STUDY_ANSWERS} answers in all", Span(path))])
    if problems:
        raise MseError(problems[:200])
    _check_sizes(answers)
    if not answers:
        raise MseError([Diagnostic("E170", "no answers in the results", Span(paths[0] if paths else "<arguments>"))])
    return tuple(answers)


def _check_sizes(answers: Sequence[Answer]) -> None:
    """E171 at the answer that brings one name too many (mse/limits.py)."""
    labels: set[str] = set()
    conditions: set[str] = set()
    stimuli: set[str] = set()
    for answer in answers:
        labels.add(answer.emotion)
        if answer.task == "label":
            labels.add(answer.response)
        conditions.update(answer.conditions)
        stimuli.add(answer.stimulus)
        for found, limit, what in ((labels, MAX_STUDY_LABELS, "emotions and labels"),
                                   (conditions, MAX_STUDY_CONDITIONS, "conditions"),
                                   (stimuli, MAX_STUDY_STIMULI, "stimuli")):
            if len(found) > limit:
                raise MseError([Diagnostic("E171", f"more than {limit} distinct {what} in the results", answer.span)])


def parse_results(text: str, path: str) -> tuple[list[Answer], list[Diagnostic]]:
    """The answers of one results table and the problems of its rows."""
    answers: list[Answer] = []
    problems: list[Diagnostic] = []
    columns: dict[str, int] | None = None
    for number, raw in enumerate(text.split("\n"), start=1):
        line = raw.removesuffix("\r")
        if not line.strip():
            continue
        try:
            cells = next(csv.reader([line], strict=True))
        except csv.Error as error:
            problems.append(Diagnostic("E170", f"not a readable CSV line ({error}; a field may not hold a line break)",
                                       Span(path, number, 1)))
            continue
        starts = _cell_columns(line)
        if columns is None:
            columns = _header(cells, starts, path, number, problems)
            if columns is None:
                return [], problems
            continue
        answer = _answer(cells, starts, columns, Span(path, number, 1), problems)
        if answer is not None:
            answers.append(answer)
        if len(problems) >= 200:
            break
    if columns is None:
        problems.append(Diagnostic("E170", "empty results file (the header row is missing)", Span(path)))
    return answers, problems


def _cell_columns(line: str) -> list[int]:
    """The 1-based column where each cell of a (single-line) CSV record starts."""
    starts = [1]
    quoted = False
    for index, char in enumerate(line):
        if char == '"':
            quoted = not quoted
        elif char == "," and not quoted:
            starts.append(index + 2)
    return starts


def _header(cells: list[str], starts: list[int], path: str, line: int,
            problems: list[Diagnostic]) -> dict[str, int] | None:
    columns: dict[str, int] = {}
    for index, cell in enumerate(cells):
        name = cell.strip().lower()
        if name in columns and name in (*REQUIRED, *OPTIONAL):
            problems.append(Diagnostic("E170", f"column {name!r} appears twice", Span(path, line, starts[index])))
            return None
        columns.setdefault(name, index)
    missing = [name for name in REQUIRED if name not in columns]
    if missing:
        problems.append(Diagnostic(
            "E170", f"the header row lacks the column{'s' if len(missing) > 1 else ''} {', '.join(missing)} "
            f"(a results table starts with {','.join((*REQUIRED, *OPTIONAL))})", Span(path, line, 1)))
        return None
    return columns


def _answer(cells: list[str], starts: list[int], columns: dict[str, int], row: Span,
            problems: list[Diagnostic]) -> Answer | None:
    before = len(problems)

    def fail(column: str, message: str) -> None:
        index = columns[column]
        col = starts[index] if index < len(starts) else 1
        problems.append(Diagnostic("E171", message, Span(row.path, row.line, col)))

    width = max(columns[name] for name in REQUIRED) + 1
    if len(cells) < width:
        problems.append(Diagnostic("E171", f"{len(cells)} cells; the header names {width} or more",
                                   Span(row.path, row.line, 1)))
        return None

    def cell(column: str) -> str:
        index = columns.get(column)
        return cells[index].strip() if index is not None and index < len(cells) else ""

    participant = cell("participant")
    if not participant:
        fail("participant", "empty participant")
    elif len(participant) > MAX_NAME_CHARS or _CONTROL.search(participant):
        fail("participant", f"participant must be at most {MAX_NAME_CHARS} printable characters")
    task = cell("task")
    if task not in TASKS:
        fail("task", f"task {task[:60]!r} must be one of {', '.join(TASKS)}")
    emotion = cell("emotion")
    _check_name(emotion, "emotion", "emotion", fail)
    condition = cell("condition")
    response = cell("response")
    conditions: tuple[str, ...] = ()
    if task == "pair":
        conditions = _pair(condition, response, fail)
    elif task == "label":
        if "|" in condition:
            fail("condition", f"a label answer has one condition, not {condition[:60]!r}")
        elif _check_name(condition, "condition", "condition", fail):
            conditions = (condition,)
        _check_name(response, "response", "response", fail)
    stimulus = cell("stimulus")
    if len(stimulus) > MAX_NAME_CHARS or _CONTROL.search(stimulus):
        fail("stimulus", f"stimulus must be at most {MAX_NAME_CHARS} printable characters")
    trial = _integer(cell("trial"))
    if cell("trial") and trial is None:
        fail("trial", f"trial {cell('trial')[:60]!r} must be a whole number from 0 (or empty)")
    seconds = _seconds(cell("seconds"))
    if cell("seconds") and seconds is None:
        fail("seconds", f"seconds {cell('seconds')[:60]!r} must be a finite number from 0 (or empty)")
    if len(problems) > before:
        return None
    return Answer(participant, task, emotion, conditions, response, stimulus, trial, seconds, row)


def _pair(condition: str, response: str, fail: Callable[[str, str], None]) -> tuple[str, ...]:
    """The two conditions of a believability pair, LEFT|RIGHT, one of them ``mse`` (() when bad)."""
    conditions = tuple(part.strip() for part in condition.split("|"))
    if len(conditions) != 2:
        fail("condition", f"a pair's condition {condition[:60]!r} must be two conditions as LEFT|RIGHT, "
             f"e.g. {MSE_CONDITION}|control")
        return ()
    names = [_check_name(part, "condition", "condition", fail) for part in conditions]  # each bad one reported
    if not all(names):
        return ()
    if conditions[0] == conditions[1]:
        fail("condition", f"a pair shows two different conditions, not {condition!r}")
    elif MSE_CONDITION not in conditions:
        fail("condition", f"a believability pair compares {MSE_CONDITION!r} with another condition, not {condition!r}")
    elif response not in conditions:
        fail("response", f"a pair's response {response[:60]!r} must be one of the conditions shown "
             f"({' or '.join(conditions)})")
    else:
        return conditions
    return ()


def _check_name(value: str, column: str, what: str, fail: Callable[[str, str], None]) -> bool:
    if not value:
        problem = f"empty {what}"
    elif len(value) > MAX_NAME_CHARS:
        problem = f"{what} is {len(value)} characters long (at most {MAX_NAME_CHARS})"
    elif not NAME.match(value):
        problem = f"{what} {value[:60]!r} must be a name of letters, digits, '_', '.', '-' (e.g. panic_fear)"
    else:
        return True
    fail(column, problem)
    return False


def _integer(text: str) -> int | None:
    if not text or not text.isascii() or not text.isdigit() or len(text) > 9:
        return None
    return int(text)


def _seconds(text: str) -> float | None:
    if not text or len(text) > 32 or not text.isascii():
        return None
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) and value >= 0 else None
