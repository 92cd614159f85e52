"""The API's sampling stage: checked options → a solver request → timelines that record their
source (``mse.sample``, ``mse.iter_timelines``, ``mse.iter_sample``), or why no timeline exists
(``mse.explain``); docs/api.md.

:mod:`mse.api` re-exports every name here and stays the documented API.

>>> import mse
>>> from mse.sampling import sample
>>> sample(mse.load("relief"), 4.0, seed=7).seed
7
"""

from __future__ import annotations

import hashlib
import random
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mse import progress
from mse.diagnostics import MseError, argument_error
from mse.ir.model import Model
from mse.ir.schedule import Schedule, to_seconds
from mse.resources import bundled_path
from mse.solve.protocol import Pin, Solver, SolveRequest, check_supported, derive_seed, get_solver
from mse.timeline import Timeline, TimelineSignal, from_schedule

if TYPE_CHECKING:
    from mse.solve.cpsat.explain import Explanation

#: The name of the default objective: every backend follows the probability profile
#: (``--objective profile``; the CP-SAT backend by perturb-and-MAP, docs/solvers.md).
DEFAULT_OBJECTIVE = "profile"


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
            raise argument_error(message)
        if not pin.start < pin.stop:
            relation = "=" if pin.start == pin.stop else ">"
            message = (
                f"pin {pin.signal}@{pin.start:g}-{pin.stop:g}: start {pin.start:g} {relation} stop {pin.stop:g} "
                "(give SIGNAL@START-STOP with START < STOP)"
            )
            raise argument_error(message)
    return pins


def _request(duration: float, seed: int | None, count: int, **options: object) -> SolveRequest:
    from mse.limits import MIN_DURATION_SECONDS, time_problem

    problem = time_problem(float(duration), minimum=MIN_DURATION_SECONDS)
    if problem is not None:
        raise argument_error(f"duration {duration!r} {problem}")
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
