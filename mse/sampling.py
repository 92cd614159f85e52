"""The sampling stage of the API: checked options → a solver request → timelines that record
their source (``mse.sample``, ``mse.iter_timelines``, ``mse.iter_sample``), or why no
timeline exists (``mse.explain``); docs/api.md.

>>> import mse
>>> mse.sample(mse.load("relief"), 4.0, seed=7).seed
7
"""

from __future__ import annotations

import hashlib
import random
import weakref
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict, Unpack

from mse import progress
from mse.diagnostics import MseError, argument_error
from mse.ir.model import Model
from mse.ir.schedule import to_seconds
from mse.limits import MIN_DURATION_SECONDS, time_problem
from mse.resources import bundled_path
from mse.solve.objectives import DEFAULT_OBJECTIVE
from mse.solve.protocol import (
    CpSatOptions,
    CspOptions,
    GreedyOptions,
    Pin,
    Solution,
    Solver,
    SolveRequest,
    check_supported,
    get_solver,
)
from mse.timeline import Timeline, TimelineSignal, from_schedule

if TYPE_CHECKING:
    from mse.solve.cpsat.explain import Explanation


class SampleOptions(TypedDict, total=False):
    """The keyword options of :func:`sample`, :func:`iter_timelines` and :func:`iter_sample`."""

    #: Signals that must occur exactly there (:class:`mse.Pin` values; one may be given alone).
    pinned: Pin | Iterable[Pin]
    #: Signal ids that must (``require``) or must not (``forbid``) occur; one may be a string.
    require: str | Iterable[str]
    forbid: str | Iterable[str]
    #: DEFAULT_OBJECTIVE ("profile") or one of :data:`mse.solve.objectives.OBJECTIVES`.
    objective: str
    #: With ``count``: maximally different timelines (cpsat).
    diverse: bool
    #: Seconds per timeline (and per window of a long cpsat one).
    time_limit: float
    #: Each backend's own options; the others ignore them.
    greedy: GreedyOptions
    cpsat: CpSatOptions
    csp: CspOptions


def expression_source(model: Model) -> dict[str, str] | None:
    """Where ``model`` was read from, as timelines record it (their ``"source"``):
    ``{"bundled": name, "sha256": ...}`` or ``{"path": absolute path, "sha256": ...}``, the
    hash being of the file's bytes when this model's first timeline was made; None when the
    model comes from no file (a string, stdin).

    >>> import mse
    >>> from mse.sampling import expression_source
    >>> expression_source(mse.load("relief"))["bundled"]
    'relief'
    """
    # Read and hashed once per model (its first timeline), not once per sample() call.
    known = _SOURCES.get(id(model))
    if known is None or known[0]() is not model:
        if len(_SOURCES) >= 64:
            _SOURCES.clear()
        known = _SOURCES[id(model)] = (weakref.ref(model), _source_of(Path(model.path)))
    source = known[1]
    return dict(source) if source is not None else None


#: id(model) -> (the model, its source): the model is held weakly, and checked, since an id
#: may be reused once it is gone.
_SOURCES: dict[int, tuple[weakref.ref[Model], dict[str, str] | None]] = {}


def _source_of(path: Path) -> dict[str, str] | None:
    from mse.input_files import read_input

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

    >>> from mse.sampling import with_source
    >>> from mse.timeline import Timeline
    >>> with_source(Timeline("x", 1.0, ()), {"path": "/x.xml", "sha256": "0"}).source
    {'path': '/x.xml', 'sha256': '0'}
    """
    if source is None:
        return timeline
    return replace(timeline, extra={**timeline.extra, "source": dict(source)})


def _names_option(value: object) -> Any:
    """``require="frown"`` is one signal, not five letters; any iterable becomes a tuple."""
    if isinstance(value, str):
        return (value,)
    return tuple(value) if isinstance(value, Iterable) else value


def _pins_option(value: object) -> tuple[Pin, ...]:
    pins = (value,) if isinstance(value, Pin) else tuple(value) if isinstance(value, Iterable) else (value,)
    for pin in pins:
        if not isinstance(pin, Pin):
            message = f"pinned takes Pin(signal, start, stop) values, not {pin!r}"
            raise argument_error(message)
        if not pin.start < pin.stop:
            relation = "=" if pin.start == pin.stop else ">"
            message = (
                f"pin {pin.signal}@{pin.start:g}-{pin.stop:g}: start {pin.start:g} {relation} stop {pin.stop:g} "
                "(give SIGNAL@START-STOP with START < STOP)"
            )
            raise argument_error(message)
    return pins


def _request(duration: float, seed: int | None, count: int, mode: str, options: SampleOptions) -> SolveRequest:
    problem = time_problem(float(duration), minimum=MIN_DURATION_SECONDS)
    if problem is not None:
        raise argument_error(f"duration {duration!r} {problem}")
    if seed is None:
        seed = random.SystemRandom().randrange(2**31)
    if not options:
        return SolveRequest(duration=float(duration), seed=seed, count=count, mode=mode)
    fields: dict[str, Any] = dict(options)
    for key in ("require", "forbid"):
        if key in fields:
            fields[key] = _names_option(fields[key])
    if "pinned" in fields:
        fields["pinned"] = _pins_option(fields["pinned"])
    if fields.get("objective") == DEFAULT_OBJECTIVE:
        del fields["objective"]  # the backend's own default: follow the probability profile
    return SolveRequest(duration=float(duration), seed=seed, count=count, mode=mode, **fields)


def sample(
    model: Model,
    duration: float = 10.0,
    *,
    seed: int | None = None,
    solver: str = "greedy",
    mode: str = "consistent",
    **options: Unpack[SampleOptions],
) -> Timeline:
    """One timeline of ``duration`` seconds (several: :func:`iter_timelines`).

    ``solver`` is ``"greedy"`` (the paper's sampler), ``"cpsat"`` (exact) or ``"csp"``;
    ``mode="constraint-less"`` ignores the constraints (the paper's control condition).
    ``options`` (:class:`SampleOptions`): ``pinned`` (:class:`mse.Pin` values), ``require``
    and ``forbid`` (signal ids; one id may be given as a string), ``objective``
    (``"profile"``, the default, ``"likely"``, ``"random"``, ``"most-signals"``,
    ``"fewest-signals"``), ``diverse``, ``time_limit``, and each backend's own options
    (``greedy=mse.GreedyOptions(...)``, ``cpsat=mse.CpSatOptions(...)``,
    ``csp=mse.CspOptions(...)``). A solver that cannot honour an option raises
    :class:`mse.MseError`; when no timeline exists it raises :class:`mse.NoSolution`.

    >>> import mse
    >>> model = mse.load("anger")
    >>> timeline = mse.sample(model, 10.0, seed=7)
    >>> timeline.duration, timeline.seed, timeline.source["bundled"]
    (10.0, 7, 'anger')
    >>> pinned = mse.sample(model, 10.0, seed=1, solver="cpsat",
    ...                     pinned=[mse.Pin("frown", 4.0, 6.0)], forbid="head_forward")
    >>> [(s.start, s.stop) for s in pinned.signals if s.id == "frown"]
    [(4.0, 6.0)]
    >>> "head_forward" in {s.id for s in pinned.signals}
    False
    """
    backend, request = _checked(duration, seed, 1, solver, mode, options)
    return _timeline(model, request, solver, expression_source(model), 0, next(backend.solutions(model, request)))


def iter_timelines(
    model: Model,
    duration: float = 10.0,
    *,
    seed: int | None = None,
    count: int = 1,
    solver: str = "greedy",
    mode: str = "consistent",
    **options: Unpack[SampleOptions],
) -> Iterator[Timeline]:
    """``count`` timelines, each yielded as soon as it is solved (memory stays flat whatever
    ``count``); options as :func:`sample`.  Timeline *i* has seed ``seed + i`` and is what
    :func:`sample` gives alone for ``seed + i``.  With ``diverse=True`` it also depends on the
    timelines before it; its JSON then records ``"diverse": {"seed": seed, "index": i}``,
    which reproduces it (``--seed seed --count i+1 --diverse``, last timeline).  The request
    is checked at once (a bad option raises here, not at the first ``next``).

    >>> import mse
    >>> model = mse.load("anger")
    >>> [t.seed for t in mse.iter_timelines(model, 10.0, seed=1, count=3)]
    [1, 2, 3]
    >>> stream = mse.iter_timelines(model, 10.0, seed=3, count=10**9)
    >>> [next(stream).seed for _ in range(2)]
    [3, 4]
    """
    backend, request = _checked(duration, seed, count, solver, mode, options)
    return _solved(backend, model, request, solver)


def _checked(duration: float, seed: int | None, count: int, solver: str, mode: str,
             options: SampleOptions) -> tuple[Solver, SolveRequest]:
    """The backend and the request, both checked (a bad option raises here, at the call)."""
    backend = get_solver(solver)
    request = _request(duration, seed, count, mode, options)
    check_supported(backend, request)
    return backend, request


def _solved(backend: Solver, model: Model, request: SolveRequest, solver: str) -> Iterator[Timeline]:
    source = expression_source(model)
    solutions = backend.solutions(model, request)
    with progress.bar(request.count, "sample", unit="timeline") as steps:
        for index, solution in enumerate(solutions):
            yield _timeline(model, request, solver, source, index, solution)
            steps.update()


def _timeline(model: Model, request: SolveRequest, solver: str, source: Mapping[str, str] | None, index: int,
              solution: Solution) -> Timeline:
    """The timeline of ``solution``, recording how it was made and where its model came from."""
    extra: dict[str, Any] = {"mode": request.mode}
    if solution.method is not None:  # how the default solver made it: "walk" or its fallback
        extra["method"] = solution.method
    if source is not None:
        extra["source"] = dict(source)
    if request.diverse:
        extra["diverse"] = {"seed": request.seed, "index": index}
    timeline = from_schedule(solution.schedule, expression=model.name, signal_info=model.signal_info,
                             solver=solver, seed=solution.seed, motions=model.motion_annotations)
    return replace(timeline, extra=extra)


def iter_sample(
    model: Model,
    duration: float = 10.0,
    *,
    seed: int | None = None,
    solver: str = "greedy",
    mode: str = "consistent",
    **options: Unpack[SampleOptions],
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
    request = _request(duration, seed, 1, mode, options)
    check_supported(backend, request)
    motions = model.motion_annotations
    for occurrence in backend.stream(model, request):
        modality, lexeme = model.signal_info[occurrence.signal]
        yield TimelineSignal(
            occurrence.signal,
            modality,
            lexeme,
            to_seconds(occurrence.start),
            to_seconds(occurrence.stop),
            motions.get(occurrence.signal),
        )


def explain(
    model: Model,
    duration: float = 10.0,
    *,
    pinned: Pin | Iterable[Pin] = (),
    require: str | Iterable[str] = (),
    forbid: str | Iterable[str] = (),
    time_limit: float = 10.0,
) -> Explanation | None:
    """Why no timeline of ``duration`` exists (a minimal conflicting set), or None.

    ``pinned``, ``require`` and ``forbid`` as for :func:`sample`.

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

    return explain_model(model, float(duration), pinned=_pins_option(pinned), require=_names_option(require),
                         forbid=_names_option(forbid), time_limit=time_limit)
