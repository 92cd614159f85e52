"""The library API: one function per stage (loading, checking, linting, learning here; sampling
in :mod:`mse.sampling`).  The CLI is a thin layer over these.

The names most users need are also importable from ``mse`` itself (``mse.load``,
``mse.sample``, ``mse.Pin``...); docs/api.md lists them all with examples.

>>> import mse
>>> model = mse.load("relief")
>>> timeline = mse.sample(model, 4.0, seed=7)
>>> mse.check(model, timeline)
[]
"""

from __future__ import annotations

import difflib
import os
from collections.abc import Iterable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mse import progress
from mse.diagnostics import Diagnostic, MseError, Span, argument_error, has_errors
from mse.ir.evaluate import Violation, check_schedule
from mse.ir.model import Model
from mse.resources import SEARCH_PATH_VARIABLE, named_set, named_sets
from mse.timeline import Timeline

__all__ = [
    "check", "compile_source", "expand_paths", "learn", "lint", "load", "loads", "loads_ir", "repair", "resolve_path",
]

# The XML reader, the grammar and the IR builder (lxml, lark) are imported inside the
# functions that parse: a model from the compiled-model cache needs none of them.

if TYPE_CHECKING:
    from collections.abc import Mapping

    from mse.learn import LearnOptions, LearnResult, TierMapping
    from mse.repairing.proposal import Proposal
    from mse.repairing.repair import Repair


def compile_source(path: str | Path, data: bytes | None = None) -> tuple[Model | None, list[Diagnostic]]:
    """Parse and resolve one native file; the model is None when there are errors.

    ``data`` (bytes) stands for the file's content when given; ``path`` then only names it
    in diagnostics. Unlike :func:`load`, errors are returned, not raised, with any warnings.

    >>> from mse.api import compile_source
    >>> model, diagnostics = compile_source("tiny.xml", b'<expression name="tiny"><signals>'
    ...     b'<signal id="a" modality="head"/></signals></expression>')
    >>> model.name, diagnostics
    ('tiny', [])
    >>> model, diagnostics = compile_source("bad.xml", b"<expression")
    >>> model is None, diagnostics[0].code
    (True, 'E101')
    """
    from mse.ir.build import build_model
    from mse.syntax.reader import read_document

    document, diagnostics = read_document(path, data)
    if document is None:
        return None, diagnostics
    model, problems = build_model(document)
    diagnostics = sorted([*diagnostics, *problems], key=Diagnostic.sort_key)
    if has_errors(diagnostics):
        return None, diagnostics
    return model, diagnostics


def resolve_path(path_or_name: str | Path) -> Path:
    """A file path as given, or the set of that name in ``$MSE_PATH``'s folders or the bundled
    sets; MseError (E100) otherwise.

    >>> from mse.api import resolve_path
    >>> resolve_path("anger").name
    'anger.xml'
    >>> resolve_path("angr")
    Traceback (most recent call last):
    mse.diagnostics.MseError: angr: E100 no such file or named expression (did you mean 'anger'?); ...
    """
    candidate = Path(path_or_name)
    if candidate.exists():
        return candidate
    named = named_set(str(path_or_name))
    if named is not None:
        return named
    names = list(named_sets())
    guess = difflib.get_close_matches(str(path_or_name), names, n=1)
    hint = f" (did you mean {guess[0]!r}?)" if guess else ""
    searched = os.environ.get(SEARCH_PATH_VARIABLE)
    where = "in $MSE_PATH or bundled" if searched else "bundled (add folders with $MSE_PATH)"
    message = f"no such file or named expression{hint}; {where}: {', '.join(names)}"
    raise MseError([Diagnostic("E100", message, Span(str(path_or_name)))])


def load(path_or_name: str | Path, *, cache: bool = False) -> Model:
    """Load a behaviour-set file, a compiled IR JSON file, or a bundled expression by name.

    With ``cache=True`` a file that compiled before is read from the compiled-model cache
    (keyed by its path and exact bytes), which skips XML parsing and the grammar. Errors
    raise :class:`mse.MseError` carrying every diagnostic (``path:line:col: CODE message``).

    >>> import mse
    >>> model = mse.load("embarrassment")
    >>> model.name, len(model.signals) > 0
    ('embarrassment', True)
    >>> model.signal("head_down").modality
    'head'
    """
    path = resolve_path(path_or_name)
    if path.suffix == ".json":
        from mse.input_files import decode_utf8, read_input

        text = decode_utf8(read_input(path, what="compiled IR file"), str(path), what="compiled IR file")
        return loads_ir(text, path=str(path))
    if cache:
        from mse.model_cache import load_cached

        return load_cached(path, compile_source)
    model, diagnostics = compile_source(path)
    if model is None:
        raise MseError(diagnostics)
    return model


def loads(data: bytes | str, *, path: str = "<string>") -> Model:
    """Load a model from the text of a native file or of compiled IR JSON; ``path`` names
    it in diagnostics. Errors raise :class:`mse.MseError`.

    >>> import mse
    >>> model = mse.loads('''<expression name="nod_then_smile">
    ...   <signals>
    ...     <signal id="nod" modality="head" min_duration="0.5" max_duration="1"/>
    ...     <signal id="smile" modality="face" min_duration="1" max_duration="3"/>
    ...   </signals>
    ...   <constraints><constraint>precedes(nod, smile)</constraint></constraints>
    ... </expression>''')
    >>> model.name, [s.id for s in model.signals]
    ('nod_then_smile', ['nod', 'smile'])
    >>> mse.loads("<expression", path="x.xml")
    Traceback (most recent call last):
    mse.diagnostics.MseError: x.xml:1:12: E101 ...
    """
    raw = data.encode("utf-8", errors="surrogateescape") if isinstance(data, str) else data
    if raw.lstrip().startswith(b"{"):
        from mse.input_files import decode_utf8

        return loads_ir(decode_utf8(raw, path, what="compiled IR"), path=path)
    model, diagnostics = compile_source(path, raw)
    if model is None:
        raise MseError(diagnostics)
    return model


def loads_ir(text: str, *, path: str = "<stdin>") -> Model:
    """A model from compiled IR JSON (``mse compile`` output), re-checked like a file.

    >>> from mse.api import load, loads_ir
    >>> from mse.ir.canonical import model_dumps
    >>> loads_ir(model_dumps(load("relief"))).name
    'relief'
    """
    from mse.input_files import parse_json
    from mse.ir.canonical import model_from_json

    return model_from_json(parse_json(text, path), path=path)


def check(model: Model, timeline: Timeline) -> list[Violation]:
    """Every way ``timeline`` is inconsistent with ``model``; empty when it is consistent.

    Each :class:`mse.Violation` has a ``span`` (the constraint's file:line) and a message.

    >>> import mse
    >>> model = mse.load("anger")
    >>> mse.check(model, mse.sample(model, 10.0, seed=1))
    []
    >>> empty = mse.Timeline("anger", 10.0, ())
    >>> [v.constraint for v in mse.check(model, empty)]
    ['angry_face_shown']
    """
    return check_schedule(model, timeline.to_schedule())


def repair(
    model: Model,
    proposal: Proposal | Timeline | Mapping[str, Any] | str,
    *,
    keep: Iterable[str] = (),
    duration: float | None = None,
    time_limit: float = 10.0,
    workers: int = 1,
    path: str = "<proposal>",
) -> Repair:
    """The consistent timeline nearest to ``proposal``, and each change with the rules
    (file:line) that forced it (docs/repair.md).

    ``proposal``: a timeline, decoded JSON (a timeline or an ``mse-proposal/1`` document) or
    text (JSON, or tagged text like ``"[nod] I [smile]really[/smile] mean it"``).  Nearest means
    first the fewest occurrences dropped or added, then the least time moved.  ``keep``: signal
    ids or occurrence ids that must not be dropped.  Bad input raises :class:`mse.MseError`
    (E218 at the proposal's line:col); :class:`mse.NoRepair` when nothing keeps ``keep``.

    >>> import mse
    >>> model = mse.load("embarrassment")
    >>> fixed = mse.repair(model, {"duration": 10, "occurrences": [
    ...     {"signal": "head_down", "start": 0.5, "stop": 3.5},
    ...     {"signal": "gaze_down", "start": 1, "stop": 2.5},
    ...     {"signal": "tensed_smile", "start": 2, "stop": 4.5}]})
    >>> [(s.id, s.start, s.stop) for s in fixed.timeline.signals]
    [('head_down', 0.5, 3.5), ('gaze_down', 1.0, 2.5), ('tensed_smile', 2.5, 4.5)]
    >>> print(fixed.summary())
    repaired for embarrassment: 0 dropped, 0 added, 1 moved by 500 ms in all, 0 foreign
    >>> print(fixed.changes[0].reasons[0].rule)
    looks_down_first
    >>> mse.check(model, fixed.timeline)
    []
    """
    from mse.repairing.repair import repair as nearest

    return nearest(model, proposal, keep=keep, duration=duration, time_limit=time_limit, workers=workers, path=path)


def expand_paths(paths: Iterable[str | Path]) -> list[Path]:
    """The files named by ``paths``: folders searched for ``*.xml``, names resolved
    (``$MSE_PATH``, then the bundled sets).

    >>> from mse.api import expand_paths
    >>> [p.name for p in expand_paths(["relief"])]
    ['relief.xml']
    """
    files: list[Path] = []
    for entry in paths:
        path = Path(entry)
        bundled = None if path.exists() else named_set(str(entry))
        if path.is_dir():
            files.extend(sorted(p for p in path.rglob("*.xml") if p.is_file()))
        else:
            files.append(bundled or path)
    return files


def _code_prefixes(prefixes: str | Sequence[str], option: str) -> tuple[str, ...]:
    """``select``/``ignore`` as a tuple (a string is comma-separated); every prefix must name
    at least one rule code, so that a typo cannot silently select or ignore nothing."""
    from mse.diagnostics import CODES

    items = prefixes.split(",") if isinstance(prefixes, str) else list(prefixes)
    cleaned = tuple(p.strip() for p in items if p.strip())
    unknown = [p for p in cleaned if not any(code.startswith(p) for code in CODES)]
    if unknown:
        names = ", ".join(repr(p) for p in unknown)
        message = f"{option} {names} matches no rule code (codes: {', '.join(CODES)})"
        raise argument_error(message)
    return cleaned


def lint(
    paths: str | Path | Sequence[str | Path],
    *,
    select: str | Sequence[str] = (),
    ignore: str | Sequence[str] = (),
    deep: bool = True,
    duration: float = 10.0,
    realizer: str | None = None,
    library_dir: str | Path | None = None,
    deep_budget: float | None = 4.0,
) -> list[Diagnostic]:
    """Errors and lint warnings of every file, as ``mse lint`` reports them.

    ``paths`` are files, folders (searched for ``*.xml``; one without any is a W300 warning)
    or bundled names. ``select``/``ignore`` are rule-code prefixes (a prefix that matches no
    code raises :class:`MseError`); ``deep`` (the default, as on the command line) adds the
    solver-backed W4xx rules at ``duration`` seconds; ``realizer="greta"`` with ``library_dir``
    (Greta's BehaviorLexicon folder) adds W308 for every signal whose lexeme Greta cannot
    resolve (docs/realizers.md). ``deep_budget`` caps the CPU seconds of the solver-backed
    questions per file (None: no cap; whether a timeline exists is always answered, and the
    questions left are listed in a W400 note).

    >>> import mse
    >>> [d.code for d in mse.lint("embarrassment")]  # notes: three constraints are rarely instantiated
    ['N407', 'N407', 'N407']
    >>> mse.lint(["embarrassment"], select=["W9"])
    Traceback (most recent call last):
    mse.diagnostics.MseError: <arguments>: E130 select 'W9' matches no rule code (codes: ...)
    """
    from mse.ir.lint import STATIC_RULES, lint_model, unknown_motion_actions
    from mse.limits import solve_duration_problem
    from mse.motion.base.starter_actions import ACTIONS as STARTER_ACTIONS

    selected = _code_prefixes(select, "select")
    ignored = _code_prefixes(ignore, "ignore")
    entries = [paths] if isinstance(paths, str | Path) else list(paths)
    problem = solve_duration_problem(duration)
    if problem is not None:
        raise argument_error(f"lint duration {problem}")
    if deep_budget is not None and not 0 < deep_budget <= 86400:  # also refuses nan
        message = f"deep budget {deep_budget:g} s is not in (0, 86400] s (no limit: --deep-budget 0, or None in Python)"
        raise argument_error(message)
    rules = (*STATIC_RULES, unknown_motion_actions(STARTER_ACTIONS))
    found: list[Diagnostic] = []
    libraries = None
    if realizer is not None:
        from mse.export.realizer_lint import realizer_libraries_for_lint

        try:
            libraries = realizer_libraries_for_lint(realizer, Path(library_dir) if library_dir is not None else None)
        except MseError as error:
            found.extend(error.diagnostics)
    for entry in entries:
        try:
            files = expand_paths([entry]) if Path(entry).is_dir() else [resolve_path(entry)]
        except MseError as error:  # neither a file nor a bundled name: say which names exist
            found.extend(error.diagnostics)
            continue
        if not files:
            found.append(Diagnostic("W300", "no behaviour-set file (*.xml) in this folder", Span(str(entry))))
        for path in progress.each(files, "lint", unit="file"):
            model, diagnostics = compile_source(path)
            found.extend(diagnostics)
            if model is None:
                continue
            found.extend(lint_model(model, rules))
            if libraries is not None:
                from mse.export.realizer_lint import lint_realizer

                found.extend(lint_realizer(model, libraries))
            if deep:
                from mse.ir.anchors import without_anchored
                from mse.solve.cpsat.deep_lint import deep_lint

                solvable = without_anchored(model)  # speech is a request's: N313 says so
                found.extend(deep_lint(solvable, duration, budget=deep_budget))
                from mse.solve.void_relations import sampled_void_relations

                found.extend(sampled_void_relations(solvable, duration))

    def wanted(diagnostic: Diagnostic) -> bool:
        if diagnostic.is_error:
            return True
        if selected and not any(diagnostic.code.startswith(prefix) for prefix in selected):
            return False
        return not any(diagnostic.code.startswith(prefix) for prefix in ignored)

    return sorted((d for d in found if wanted(d)), key=Diagnostic.sort_key)


def learn(
    paths: Sequence[str | Path],
    options: LearnOptions | None = None,
    mapping: TierMapping | None = None,
    **settings: Any,
) -> LearnResult:
    """Learn a behaviour set from ELAN files, CSV/TSV tables or timelines (docs/learn.md).

    ``settings`` are fields of :class:`mse.learn.LearnOptions` (name, confidence,
    min_support, significance, calibrate...); the result has ``xml``, ``model``, ``rules``
    with their evidence and ``breaks`` (corpus sequences the learned set rejects).

    >>> import tempfile
    >>> from mse.timeline import dumps_jsonl
    >>> corpus = Path(tempfile.mkdtemp()) / "relief.jsonl"
    >>> from mse.sampling import iter_timelines
    >>> _ = corpus.write_text(dumps_jsonl(iter_timelines(load("relief"), 10.0, seed=1, count=40)))
    >>> result = learn([corpus], name="relief", confidence=1.0, calibrate=False, deep_lint=False)
    >>> result.breaks, len(result.model.signals)
    ([], 9)
    """

    from mse.learn import LearnOptions as Options
    from mse.learn import TierMapping as Mapping
    from mse.learn import learn as learn_files

    chosen = replace(options or Options(), **settings)
    return learn_files(paths, chosen, mapping or Mapping())
