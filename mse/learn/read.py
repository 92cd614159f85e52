"""Every input of ``mse learn`` into one corpus: ELAN files, CSV/TSV tables, mse timelines.

The kind of a file is told by its suffix: ``.eaf`` (ELAN), ``.csv``/``.tsv``/``.tab``
(tables), ``.json``/``.jsonl`` (mse timelines: tier = modality, label = signal id).  A folder
is searched for those suffixes.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from mse import progress
from mse.diagnostics import Diagnostic, MseError, Span, has_errors
from mse.ir.build import IDENTIFIER
from mse.ir.schedule import to_ticks
from mse.learn.corpus import DEFAULT_MAPPING, Annotation, Corpus, RawSequence, TierMapping, build_corpus
from mse.learn.read_eaf import read_eaf
from mse.learn.read_table import read_table
from mse.limits import MAX_LEARN_ANNOTATIONS, MAX_LEARN_SIGNALS, MAX_SOLVE_SECONDS
from mse.syntax.reader import decode_text, read_bytes

SUFFIXES: dict[str, str] = {
    ".eaf": "eaf",
    ".csv": "table",
    ".tsv": "table",
    ".tab": "table",
    ".json": "timelines",
    ".jsonl": "timelines",
}


def expand_inputs(paths: Iterable[str | Path]) -> tuple[list[Path], list[Diagnostic]]:
    files: list[Path] = []
    problems: list[Diagnostic] = []
    for entry in paths:
        path = Path(entry)
        if path.is_dir():
            inside = sorted(p for p in path.rglob("*") if p.is_file() and p.suffix.lower() in SUFFIXES)
            if not inside:
                problems.append(Diagnostic("E100", f"no annotation file ({', '.join(SUFFIXES)}) in this folder",
                                           Span(str(path))))
            files.extend(inside)
        elif path.suffix.lower() not in SUFFIXES:
            problems.append(Diagnostic("E100", f"unknown kind of annotation file (suffixes: {', '.join(SUFFIXES)})",
                                       Span(str(path))))
        else:
            files.append(path)
    return files, problems


def read_timeline_sequences(path: Path, data: bytes) -> tuple[list[RawSequence], list[Diagnostic]]:
    from mse.timeline import loads_many

    name = str(path)
    try:
        timelines = loads_many(decode_text(data), path=name)
    except MseError as error:
        return [], list(error.diagnostics)
    sequences = []
    for index, timeline in enumerate(timelines):
        span = Span(name, index + 1 if len(timelines) > 1 else 0, 1 if len(timelines) > 1 else 0)
        annotations = []
        for signal in timeline.signals:
            start, stop = to_ticks(signal.start), to_ticks(signal.stop)
            if not 0 <= start < stop:
                return [], [Diagnostic("E212", f"signal {signal.id!r} must have 0 <= start < stop", span)]
            if signal.modality and not IDENTIFIER.match(signal.modality):
                return [], [Diagnostic("E212", f"signal {signal.id[:60]!r} has the modality {signal.modality[:60]!r}, "
                                       "which is not an identifier ([A-Za-z_][A-Za-z0-9_]*)", span)]
            action = signal.motion.get("action") if signal.motion else None
            annotations.append(Annotation(signal.modality or "unknown", signal.id, start, stop, span,
                                          lexeme=signal.lexeme, motion=str(action) if action else None,
                                          modality=signal.modality or None))
        duration = to_ticks(timeline.duration)
        if any(a.stop > duration for a in annotations):
            return [], [Diagnostic("E212", "a signal stops after the timeline's duration", span)]
        label = f"{path.stem}#{index + 1}" if len(timelines) > 1 else path.stem
        sequences.append(RawSequence(label, tuple(annotations), span, duration))
    return sequences, []


#: Largest table or timeline file read (an ELAN file keeps the XML reader's 10 MB limit).
MAX_CORPUS_BYTES = 128 * 1024 * 1024


def _read(path: Path, kind: str) -> tuple[bytes | None, list[Diagnostic]]:
    if kind == "eaf":
        return read_bytes(path)
    from mse.input_files import read_input

    try:  # regular files only, never more than the limit (mse.fileio)
        return read_input(path, limit=MAX_CORPUS_BYTES), []
    except MseError as error:
        return None, list(error.diagnostics)


def read_corpus(paths: Iterable[str | Path], mapping: TierMapping = DEFAULT_MAPPING) -> tuple[Corpus, list[Diagnostic]]:
    """The corpus of every input; raises MseError (every problem, with file:line) on bad input."""
    files, found = expand_inputs(paths)
    raw: list[RawSequence] = []
    for path in progress.each(files, "read", unit="file"):
        kind = SUFFIXES[path.suffix.lower()]
        data, problems = _read(path, kind)
        found.extend(problems)
        if data is None:
            continue
        if kind == "eaf":
            sequence, problems = read_eaf(path, data)
            found.extend(problems)
            if sequence is not None:
                raw.append(sequence)
        elif kind == "table":
            sequences, problems = read_table(path, data)
            found.extend(problems)
            raw.extend(sequences)
        else:
            sequences, problems = read_timeline_sequences(path, data)
            found.extend(problems)
            raw.extend(sequences)
    found.extend(_too_long(raw))
    annotations = sum(len(sequence.annotations) for sequence in raw)
    if annotations > MAX_LEARN_ANNOTATIONS:
        where = str(files[0]) if files else "<input>"
        found.append(Diagnostic("E122", f"{annotations} annotations; learn mines at most {MAX_LEARN_ANNOTATIONS} "
                                "(learn from a sample of the sequences)", Span(where)))
    if has_errors(found):
        raise MseError(found)
    corpus, notes = build_corpus(raw, mapping)
    found.extend(notes)
    if len(corpus.signals) > MAX_LEARN_SIGNALS:
        where = str(files[0]) if files else "<input>"
        found.append(Diagnostic("E122", f"{len(corpus.signals)} distinct signals; learn mines at most "
                                f"{MAX_LEARN_SIGNALS} (map labels together with --mapping, or read fewer tiers)",
                                Span(where)))
    if has_errors(found):
        raise MseError(found)
    if not corpus.sequences or not corpus.signals:
        where = str(files[0]) if files else "<input>"
        found.append(Diagnostic("E121", "no annotation to learn from (check --tiers and the files)", Span(where)))
        raise MseError(found)
    return corpus, found


def _too_long(raw: Iterable[RawSequence]) -> list[Diagnostic]:
    """E121 for each sequence longer than ``sample`` solves (MAX_SOLVE_SECONDS): the learned
    set is checked and calibrated by sampling at the sequences' length."""
    found = []
    limit = round(MAX_SOLVE_SECONDS * 1000)
    for sequence in raw:
        length = sequence.duration if sequence.duration is not None else max(
            (a.stop for a in sequence.annotations), default=0)
        if length > limit:
            found.append(Diagnostic("E122", f"sequence {sequence.name!r} is {length / 1000:g} s long; learn reads "
                                    f"sequences of at most {MAX_SOLVE_SECONDS:g} s (the longest that sample "
                                    "solves): cut the recording into shorter sequences", sequence.span))
    return found
