"""The library API: one function per stage.  The CLI is a thin layer over these.

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
import hashlib
import random
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mse import progress
from mse.diagnostics import Diagnostic, MseError, Span, has_errors
from mse.ir.evaluate import Violation, check_schedule
from mse.ir.model import Model
from mse.ir.schedule import Schedule, to_seconds
from mse.resources import bundled_names, bundled_path
from mse.solve.protocol import Pin, Solver, SolveRequest, check_supported, derive_seed, get_solver
from mse.timeline import Timeline, TimelineSignal, from_schedule

#: The name of the default objective: every backend follows the probability profile
#: (``--objective profile``; the CP-SAT backend by perturb-and-MAP, docs/solvers.md).
DEFAULT_OBJECTIVE = "profile"

# The XML reader, the grammar and the IR builder (lxml, lark) are imported inside the
# functions that parse: a model from the compiled-model cache needs none of them.

if TYPE_CHECKING:
    from mse.learn import LearnOptions, LearnResult, TierMapping
    from mse.solve.cpsat.explain import Explanation


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
    """A file path as given, or the bundled file of that name; MseError (E100) otherwise.

    >>> from mse.api import resolve_path
    >>> resolve_path("anger").name
    'anger.xml'
    >>> resolve_path("angr")
    Traceback (most recent call last):
    mse.diagnostics.MseError: angr: E100 no such file or bundled expression (did you mean 'anger'?); bundled: ...
    """
    candidate = Path(path_or_name)
    if candidate.exists():
        return candidate
    bundled = bundled_path(str(path_or_name))
    if bundled is not None:
        return bundled
    names = bundled_names()
    guess = difflib.get_close_matches(str(path_or_name), names, n=1)
    hint = f" (did you mean {guess[0]!r}?)" if guess else ""
    message = f"no such file or bundled expression{hint}; bundled: {', '.join(names)}"
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
        from mse.fileio import decode_utf8, read_input

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
        from mse.fileio import decode_utf8

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
    from mse.fileio import parse_json
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


def expand_paths(paths: Iterable[str | Path]) -> list[Path]:
    """The files named by ``paths``: folders searched for ``*.xml``, bundled names resolved.

    >>> from mse.api import expand_paths
    >>> [p.name for p in expand_paths(["relief"])]
    ['relief.xml']
    """
    files: list[Path] = []
    for entry in paths:
        path = Path(entry)
        bundled = None if path.exists() else bundled_path(str(entry))
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
        raise MseError([Diagnostic("E100", message, Span("<arguments>"))])
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
    >>> [d.code for d in mse.lint("embarrassment")]
    []
    >>> mse.lint(["embarrassment"], select=["W9"])
    Traceback (most recent call last):
    mse.diagnostics.MseError: <arguments>: E100 select 'W9' matches no rule code (codes: ...)
    """
    from mse.ir.lint import STATIC_RULES, lint_model, unknown_motion_actions
    from mse.limits import solve_duration_problem
    from mse.motion.base.starter_actions import ACTIONS as STARTER_ACTIONS

    selected = _code_prefixes(select, "select")
    ignored = _code_prefixes(ignore, "ignore")
    entries = [paths] if isinstance(paths, str | Path) else list(paths)
    problem = solve_duration_problem(duration)
    if problem is not None:
        raise MseError([Diagnostic("E100", f"lint duration {problem}", Span("<arguments>"))])
    if deep_budget is not None and not 0 < deep_budget <= 86400:  # also refuses nan
        message = f"deep budget {deep_budget:g} s is not in (0, 86400] s (no limit: --deep-budget 0, or None in Python)"
        raise MseError([Diagnostic("E100", message, Span("<arguments>"))])
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
                from mse.solve.cpsat.deep_lint import deep_lint

                found.extend(deep_lint(model, duration, budget=deep_budget))

    def wanted(diagnostic: Diagnostic) -> bool:
        if diagnostic.is_error:
            return True
        if selected and not any(diagnostic.code.startswith(prefix) for prefix in selected):
            return False
        return not any(diagnostic.code.startswith(prefix) for prefix in ignored)

    return sorted((d for d in found if wanted(d)), key=Diagnostic.sort_key)


def motion_annotations(model: Model) -> dict[str, dict[str, object]]:
    """``{"action": ...}`` for every motion-leaf signal (timeline entries carry it).

    >>> from mse.api import load, motion_annotations
    >>> motion_annotations(load("embarrassment"))["bow"]
    {'action': 'bow'}
    """
    return {s.id: {"action": s.motion.action} for s in model.signals if s.motion is not None}


def expression_source(model: Model) -> dict[str, str] | None:
    """Where ``model`` was read from, as timelines record it (their ``"source"``):
    ``{"bundled": name, "sha256": ...}`` or ``{"path": absolute path, "sha256": ...}``, the
    hash being of the file's bytes; None when the model comes from no file (a string, stdin).

    >>> import mse
    >>> from mse.api import expression_source
    >>> expression_source(mse.load("relief"))["bundled"]
    'relief'
    """
    from mse.fileio import read_input

    path = Path(model.path)
    try:  # a path named by compiled IR may be anything: a regular file, capped, or nothing
        data = read_input(path) if path.is_file() else None
    except (MseError, ValueError):
        data = None
    if data is None:
        return None
    digest = hashlib.sha256(data).hexdigest()
    resolved = path.resolve()
    bundled = bundled_path(resolved.stem)
    if bundled is not None and bundled.resolve() == resolved:
        return {"bundled": resolved.stem, "sha256": digest}
    return {"path": str(resolved), "sha256": digest}


def with_source(timeline: Timeline, source: Mapping[str, str] | None) -> Timeline:
    """``timeline`` recording ``source`` (see :func:`expression_source`) in its JSON.

    >>> from mse.api import with_source
    >>> from mse.timeline import Timeline
    >>> with_source(Timeline("x", 1.0, ()), {"path": "/x.xml", "sha256": "0"}).source
    {'path': '/x.xml', 'sha256': '0'}
    """
    if source is None:
        return timeline
    return replace(timeline, extra={**timeline.extra, "source": dict(source)})


def _names_option(value: object) -> object:
    """``require="frown"`` is one signal, not five letters; any iterable becomes a tuple."""
    if isinstance(value, str):
        return (value,)
    return tuple(value) if isinstance(value, Iterable) else value


def _pins_option(value: object) -> tuple[Pin, ...]:
    pins = (value,) if isinstance(value, Pin) else tuple(value) if isinstance(value, Iterable) else (value,)
    for pin in pins:
        if not isinstance(pin, Pin):
            message = f"pinned takes Pin(signal, start, stop) values, not {pin!r}"
            raise MseError([Diagnostic("E100", message, Span("<arguments>"))])
        if not pin.start < pin.stop:
            relation = "=" if pin.start == pin.stop else ">"
            message = (
                f"pin {pin.signal}@{pin.start:g}-{pin.stop:g}: start {pin.start:g} {relation} stop {pin.stop:g} "
                "(give SIGNAL@START-STOP with START < STOP)"
            )
            raise MseError([Diagnostic("E100", message, Span("<arguments>"))])
    return pins


def _request(duration: float, seed: int | None, count: int, **options: object) -> SolveRequest:
    from mse.limits import MIN_DURATION_SECONDS, time_problem

    problem = time_problem(float(duration), minimum=MIN_DURATION_SECONDS)
    if problem is not None:
        raise MseError([Diagnostic("E100", f"duration {duration!r} {problem}", Span("<arguments>"))])
    if seed is None:
        seed = random.SystemRandom().randrange(2**31)
    for key in ("require", "forbid"):
        if key in options:
            options[key] = _names_option(options[key])
    if "pinned" in options:
        options["pinned"] = _pins_option(options["pinned"])
    if options.get("objective") == DEFAULT_OBJECTIVE:
        del options["objective"]  # the backend's own default: follow the probability profile
    return SolveRequest(duration=float(duration), seed=seed, count=count, **options)  # type: ignore[arg-type]


def sample(
    model: Model,
    duration: float = 10.0,
    *,
    seed: int | None = None,
    count: int | None = None,
    solver: str = "greedy",
    mode: str = "consistent",
    **options: object,
) -> Timeline | list[Timeline]:
    """One timeline (``count=None``) or a list of ``count`` timelines of ``duration`` seconds.

    ``solver`` is ``"greedy"`` (the paper's sampler), ``"cpsat"`` (exact) or ``"csp"``;
    ``mode="constraint-less"`` ignores the constraints (the paper's control condition).
    ``options`` are the fields of :class:`mse.SolveRequest`: ``pinned`` (:class:`mse.Pin`
    values), ``require`` and ``forbid`` (signal ids; one id may be given as a string),
    ``objective`` (``"profile"``, the default, ``"likely"``, ``"random"``, ``"most-signals"``,
    ``"fewest-signals"``), ``diverse``, ``time_limit``, ``workers``, ``grid``, ``slot``,
    ``max_restarts``. A solver that cannot honour an option raises :class:`mse.MseError`;
    when no timeline exists it raises :class:`mse.NoSolution`. Timeline *i* of a ``count``
    run has seed ``seed + i``.

    >>> import mse
    >>> model = mse.load("anger")
    >>> timeline = mse.sample(model, 10.0, seed=7)
    >>> timeline.duration, timeline.seed, timeline.source["bundled"]
    (10.0, 7, 'anger')
    >>> [t.seed for t in mse.sample(model, 10.0, seed=1, count=3)]
    [1, 2, 3]
    >>> pinned = mse.sample(model, 10.0, seed=1, solver="cpsat",
    ...                     pinned=[mse.Pin("frown", 4.0, 6.0)], forbid="head_forward")
    >>> [(s.start, s.stop) for s in pinned.signals if s.id == "frown"]
    [(4.0, 6.0)]
    >>> "head_forward" in {s.id for s in pinned.signals}
    False
    """
    timelines = list(iter_timelines(model, duration, seed=seed, count=count or 1, solver=solver, mode=mode,
                                    **options))
    return timelines if count is not None else timelines[0]


def iter_timelines(
    model: Model,
    duration: float = 10.0,
    *,
    seed: int | None = None,
    count: int = 1,
    solver: str = "greedy",
    mode: str = "consistent",
    **options: object,
) -> Iterator[Timeline]:
    """The timelines of :func:`sample`, each yielded as soon as it is solved (memory stays
    flat whatever ``count``).  Timeline *i* has seed ``seed + i`` and is what ``count=None,
    seed=seed + i`` gives alone.  With ``diverse=True`` it also depends on the timelines before
    it; its JSON then records ``"diverse": {"seed": seed, "index": i}``, which reproduces it
    (``--seed seed --count i+1 --diverse``, last timeline).

    >>> import mse
    >>> stream = mse.iter_timelines(mse.load("anger"), 10.0, seed=3, count=10**9)
    >>> [next(stream).seed for _ in range(2)]
    [3, 4]
    """
    backend = get_solver(solver)
    request = _request(duration, seed, count, mode=mode, **options)
    check_supported(backend, request)
    motions = motion_annotations(model)
    source = expression_source(model)
    # How each timeline was made (the default solver: "walk" or its fallback) and the mode.
    schedules: Iterable[tuple[Schedule, str | None]]
    if request.diverse:
        # each one depends on those before it
        together = backend.solve(model, request)
        methods: list[str] = list(getattr(backend, "methods", ()))
        schedules = ((schedule, methods[index] if index < len(methods) else None)
                     for index, schedule in enumerate(together))
    else:
        schedules = (_one(backend, model, replace(request, seed=derive_seed(request.seed, index), count=1))
                     for index in progress.each(range(count), "sample", unit="timeline"))
    for index, (schedule, method) in enumerate(schedules):
        timeline = with_source(
            replace(
                from_schedule(
                    schedule,
                    expression=model.name,
                    signal_info=model.signal_info,
                    solver=solver,
                    seed=derive_seed(request.seed, index),
                    motions=motions,
                ),
                extra={"mode": request.mode, **({"method": method} if method is not None else {})},
            ),
            source,
        )
        if request.diverse:
            timeline = replace(timeline, extra={**timeline.extra, "diverse": {"seed": request.seed, "index": index}})
        yield timeline


def _one(backend: Solver, model: Model, request: SolveRequest) -> tuple[Schedule, str | None]:
    """The one timeline of ``request`` (count 1) and how it was made, when the backend says."""
    schedule = backend.solve(model, request)[0]
    methods = list(getattr(backend, "methods", ()))
    return schedule, (methods[0] if methods else None)


def iter_sample(
    model: Model,
    duration: float = 10.0,
    *,
    seed: int | None = None,
    solver: str = "greedy",
    **options: object,
) -> Iterator[TimelineSignal]:
    """The signals of one timeline, each yielded as soon as the solver decides it (a solver
    that decides a whole timeline at once hands its signals out in order); options as
    :func:`sample`.

    >>> import mse
    >>> model = mse.load("relief")
    >>> signals = list(mse.iter_sample(model, 10.0, seed=7))
    >>> all(0 <= s.start < s.stop <= 10.0 for s in signals)
    True
    """
    backend = get_solver(solver)
    request = _request(duration, seed, 1, **options)
    check_supported(backend, request)
    motions = motion_annotations(model)
    occurrences = (backend.stream(model, request) if "stream" in backend.supports
                   else iter(backend.solve(model, request)[0].occurrences))
    for occurrence in occurrences:
        modality, lexeme = model.signal_info[occurrence.signal]
        yield TimelineSignal(
            occurrence.signal,
            modality,
            lexeme,
            to_seconds(occurrence.start),
            to_seconds(occurrence.stop),
            motions.get(occurrence.signal),
        )


def explain(model: Model, duration: float = 10.0, **options: Any) -> Explanation | None:
    """Why no timeline of ``duration`` exists (a minimal conflicting set), or None.

    Options: ``pinned``, ``require``, ``forbid`` as for :func:`sample`, and a ``time_limit``.

    >>> import mse
    >>> model = mse.loads('''<expression name="tiny"><signals>
    ...   <signal id="a" modality="head" min_duration="3"/></signals>
    ...   <constraints><constraint id="needs_a">exists(a)</constraint></constraints>
    ... </expression>''')
    >>> mse.explain(model, 5.0) is None
    True
    >>> print(mse.explain(model, 2.0).render())
    no timeline of 2 s: ...needs_a (<string>:3) exists(a)
    """
    from mse.solve.cpsat.explain import explain as explain_model

    for key in ("require", "forbid"):
        if key in options:
            options[key] = _names_option(options[key])
    if "pinned" in options:
        options["pinned"] = _pins_option(options["pinned"])
    return explain_model(model, float(duration), **options)


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
    >>> _ = corpus.write_text(dumps_jsonl(sample(load("relief"), 10.0, seed=1, count=40)))
    >>> result = learn([corpus], name="relief", confidence=1.0, calibrate=False, deep_lint=False)
    >>> result.breaks, len(result.model.signals)
    ([], 9)
    """
    from dataclasses import replace

    from mse.learn import LearnOptions as Options
    from mse.learn import TierMapping as Mapping
    from mse.learn import learn as learn_files

    chosen = replace(options or Options(), **settings)
    return learn_files(paths, chosen, mapping or Mapping())
