"""``mse.repair(model, proposal)``: the nearest consistent timeline and what changed, and why.

Each change names the rules that forced it.  The repair *R* is optimal, so undoing one of its
changes alone (putting a moved occurrence back where it was proposed, restoring a dropped
one, removing an added one) gives a timeline that is strictly nearer to the proposal, hence
inconsistent: the rules the evaluator finds broken in it are the change's reasons, each with
its ``file:line``.
"""

from __future__ import annotations

import json
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from mse.diagnostics import Diagnostic, MseError, Span
from mse.ir import model as ir
from mse.ir.evaluate import Violation, check_schedule
from mse.ir.schedule import Occurrence, Schedule, to_seconds
from mse.repairing.nearest import Placed, Solved, keep_core, restricted, solve, where
from mse.repairing.proposal import Proposal, ProposedOccurrence
from mse.solve.cpsat.encoding import Item
from mse.timeline import Timeline, TimelineSignal

ChangeKind = Literal["moved", "dropped", "added", "foreign"]
REPORT_FORMAT = "mse-repair-report/1"
#: A proposed occurrence the set does not know (reported, left out).
FOREIGN = "W701"
#: No repair keeps what must be kept (or no timeline of that duration exists at all).
NO_REPAIR = "E702"


@dataclass(frozen=True, slots=True)
class Reason:
    """A rule that forced a change: undoing the change alone breaks it."""

    rule: str  # the constraint's id, else the kind of occurrence rule (duration, exclusive...)
    kind: str
    span: Span
    message: str

    def render(self) -> str:
        return f"{self.rule} ({where(self.span)}) {self.message}"


@dataclass(frozen=True, slots=True)
class Change:
    """One difference between the proposal and the repaired timeline.  ``start``/``stop``
    (ticks) are the occurrence in the repaired timeline; None when dropped or foreign."""

    kind: ChangeKind
    signal: str
    proposed: ProposedOccurrence | None
    start: int | None = None
    stop: int | None = None
    reasons: tuple[Reason, ...] = ()
    path: str = "<proposal>"

    @property
    def moved(self) -> int:
        """Milliseconds moved: ``|Δstart| + |Δstop|`` (moved changes only)."""
        if self.kind != "moved" or self.proposed is None or self.start is None or self.stop is None:
            return 0
        return abs(self.start - self.proposed.start) + abs(self.stop - self.proposed.stop)

    @property
    def span(self) -> Span:
        """Where the proposal wrote the occurrence (an added one: the proposal itself)."""
        return self.proposed.span if self.proposed is not None else Span(self.path)

    def describe(self) -> str:
        here = f"[{_s(self.start)}, {_s(self.stop)}] s" if self.start is not None else ""
        if self.kind == "foreign":
            assert self.proposed is not None
            return f"{self.proposed.describe()} names no signal of the set: left out of the repair"
        if self.kind == "added":
            return f"added {self.signal} {here}"
        assert self.proposed is not None
        if self.kind == "dropped":
            return f"dropped {self.proposed.describe()}"
        return f"moved {self.proposed.describe()} to {here} ({self.moved} ms)"

    def render(self) -> str:
        """``path:line:col: moved smile [1, 3] s to [1.5, 3.5] s (1000 ms): because …``."""
        code = f"{FOREIGN} " if self.kind == "foreign" else ""
        because = ""
        if self.kind != "foreign":
            because = (": because of " + " … ".join(r.render() for r in self.reasons) if self.reasons
                       else ": (no single rule: the repair is not proven optimal)")
        return f"{self.span.render()}: {code}{self.describe()}{because}"

    def to_json(self) -> dict[str, Any]:
        entry: dict[str, Any] = {"change": self.kind, "signal": self.signal}
        if self.proposed is not None:
            proposed: dict[str, Any] = {"name": self.proposed.name, "start": _s(self.proposed.start),
                                        "stop": _s(self.proposed.stop), "at": self.proposed.span.render()}
            if self.proposed.label:
                proposed["id"] = self.proposed.label
            if self.proposed.estimated:
                proposed["estimated"] = True
            entry["proposed"] = proposed
        if self.start is not None and self.stop is not None:
            entry["start"], entry["stop"] = _s(self.start), _s(self.stop)
        if self.kind == "moved":
            entry["moved_ms"] = self.moved
        if self.kind != "foreign":
            entry["because"] = [{"rule": r.rule, "kind": r.kind, "at": where(r.span), "message": r.message}
                                for r in self.reasons]
        return entry


@dataclass(frozen=True)
class Repair:
    """The repaired timeline, the changes from the proposal (in proposal order, added ones
    last), and whether CP-SAT proved it the nearest (``optimal``)."""

    timeline: Timeline
    changes: tuple[Change, ...]
    proposal: Proposal
    optimal: bool = True
    seconds: float = 0.0  # time CP-SAT took (0 when the proposal was consistent)
    expression: str = field(default="", compare=False)

    @property
    def unchanged(self) -> bool:
        """The proposal was consistent and every occurrence named a signal of the set."""
        return not self.changes

    def count(self, kind: ChangeKind) -> int:
        return sum(1 for change in self.changes if change.kind == kind)

    @property
    def moved(self) -> int:
        """Total milliseconds moved (unweighted)."""
        return sum(change.moved for change in self.changes)

    def summary(self) -> str:
        if self.unchanged:
            return f"the proposal is consistent with {self.expression}: unchanged"
        proof = "" if self.optimal else " (not proven nearest: the time limit ran out)"
        return (f"repaired for {self.expression}: {self.count('dropped')} dropped, {self.count('added')} added, "
                f"{self.count('moved')} moved by {self.moved} ms in all, {self.count('foreign')} foreign{proof}")

    def render(self) -> list[str]:
        return [change.render() for change in self.changes] + [self.summary()]

    def to_json(self) -> dict[str, Any]:
        return {
            "format": REPORT_FORMAT,
            "expression": self.expression,
            "proposal": self.proposal.path,
            "form": self.proposal.form,
            "unchanged": self.unchanged,
            "optimal": self.optimal,
            "dropped": self.count("dropped"),
            "added": self.count("added"),
            "moved": self.count("moved"),
            "moved_ms": self.moved,
            "foreign": self.count("foreign"),
            "changes": [change.to_json() for change in self.changes],
        }

    def dumps_report(self) -> str:
        return json.dumps(self.to_json(), indent=2, ensure_ascii=False)


class NoRepair(MseError):
    """No timeline keeps what must be kept (``proven``), or none was found in the time limit.
    ``items``: a minimal set of rules that cannot hold together (``minimal`` False when the
    shrinking ran out of time)."""

    def __init__(self, diagnostics: list[Diagnostic], items: Sequence[Item] = (), *, proven: bool,
                 minimal: bool = True) -> None:
        super().__init__(diagnostics)
        self.items = tuple(items)
        self.proven = proven
        self.minimal = minimal


def _s(ticks: int | None) -> float:
    return to_seconds(ticks or 0)


# -- the entry point --------------------------------------------------------------------------
def repair(
    model: ir.Model,
    proposal: Proposal | Timeline | Mapping[str, Any] | str,
    *,
    keep: Iterable[str] = (),
    duration: float | None = None,
    time_limit: float = 10.0,
    workers: int = 1,
    path: str = "<proposal>",
) -> Repair:
    """The consistent timeline nearest to ``proposal`` (docs/repair.md).

    ``proposal``: a :class:`Proposal`, a :class:`~mse.timeline.Timeline`, decoded JSON (a timeline
    or an ``mse-proposal/1`` document) or text (JSON, or tagged text).  ``keep``: signal ids or
    occurrence ids whose proposed occurrences must not be dropped.  Raises MseError (E218: bad
    proposal; E100: a ``keep`` that names nothing) and :class:`NoRepair` when no timeline keeps
    them.
    """
    read = as_proposal(model, proposal, duration=duration, path=path)
    indices = _keep_indices(read, keep)
    expression = model.name
    foreign = [Change("foreign", o.name, o) for o in read.foreign]
    if not check_schedule(model, read.schedule()):
        if not foreign and read.timeline is not None:
            return Repair(read.timeline, (), read, expression=expression)
        placed = tuple(Placed(o.signal, o.start, o.stop, i) for i, o in enumerate(read.occurrences)
                       if o.signal is not None)
        return Repair(_timeline(model, read, placed), tuple(foreign), read, expression=expression)
    solved, status, failing = solve(model, read, indices, time_limit=time_limit, workers=workers)
    if solved is None:
        assert failing is not None
        raise _no_repair(failing, read, indices, status, time_limit, workers)
    changes = _changes(model, read, solved)
    ordered = sorted(changes + foreign, key=_order(read))
    return Repair(_timeline(model, read, solved.placed), tuple(ordered), read, solved.optimal, solved.seconds,
                  expression=expression)


def as_proposal(model: ir.Model, proposal: Proposal | Timeline | Mapping[str, Any] | str, *,
                duration: float | None = None, path: str = "<proposal>") -> Proposal:
    """Any accepted form of a proposal, read for ``model``."""
    from mse.repairing.read import from_json, read_proposal

    if isinstance(proposal, Proposal):
        return proposal
    if isinstance(proposal, Timeline):
        return from_json(model, proposal.to_json(), path=path, duration=duration, timeline=proposal)
    if isinstance(proposal, str):
        return read_proposal(model, proposal, path=path, duration=duration)
    return from_json(model, dict(proposal), path=path, duration=duration)


def _keep_indices(proposal: Proposal, keep: Iterable[str]) -> frozenset[int]:
    """Indices of the occurrences ``keep`` names (by signal id or by occurrence id), plus those
    the proposal marks ``keep``."""
    found = {i for i, o in enumerate(proposal.occurrences) if o.keep and o.signal is not None}
    for name in keep:
        named = {i for i, o in enumerate(proposal.occurrences)
                 if o.signal is not None and name in (o.signal, o.label)}
        if not named:
            foreign = any(name in (o.name, o.label) for o in proposal.foreign)
            why = ("it names no signal of the set" if foreign else
                   "no proposed occurrence has that signal or id")
            raise MseError([Diagnostic("E100", f"--keep {name!r}: {why}", Span("<arguments>"))])
        found |= named
    return frozenset(found)


def _order(proposal: Proposal) -> Any:
    position = {id(o): i for i, o in enumerate(proposal.occurrences)}

    def key(change: Change) -> tuple[int, int, str]:
        if change.proposed is not None:
            return (0, position[id(change.proposed)], "")
        return (1, change.start or 0, change.signal)

    return key


def _timeline(model: ir.Model, proposal: Proposal, placed: Sequence[Placed]) -> Timeline:
    signals = []
    for occurrence in placed:
        signal = model.signal(occurrence.signal)
        motion = {"action": signal.motion.action} if signal.motion is not None else None
        signals.append(TimelineSignal(signal.id, signal.modality, signal.lexeme, to_seconds(occurrence.start),
                                      to_seconds(occurrence.stop), motion))
    return Timeline(model.name, to_seconds(proposal.duration), tuple(signals), "repair", None)


def _changes(model: ir.Model, proposal: Proposal, solved: Solved) -> list[Change]:
    """Each change with its reasons: the rules broken when that change alone is undone."""
    placed = list(solved.placed)
    kept = {p.source for p in placed if p.source is not None}
    changes: list[Change] = []

    def reasons(occurrences: Iterable[Occurrence]) -> tuple[Reason, ...]:
        if not solved.optimal:
            return ()
        return tuple(_reason(v) for v in check_schedule(model, Schedule.of(proposal.duration, occurrences)))

    current = [Occurrence(p.start, p.stop, p.signal) for p in placed]
    for index, occurrence in enumerate(proposal.occurrences):
        if occurrence.signal is None or index in kept:
            continue
        back = Occurrence(occurrence.start, occurrence.stop, occurrence.signal)
        changes.append(Change("dropped", occurrence.signal, occurrence, reasons=reasons([*current, back])))
    for position, p in enumerate(placed):
        others = current[:position] + current[position + 1:]
        if p.source is None:
            changes.append(Change("added", p.signal, None, p.start, p.stop, reasons(others), proposal.path))
            continue
        proposed = proposal.occurrences[p.source]
        if (p.start, p.stop) != (proposed.start, proposed.stop):
            back = Occurrence(proposed.start, proposed.stop, p.signal)
            changes.append(Change("moved", p.signal, proposed, p.start, p.stop, reasons([*others, back])))
    return changes


def _reason(violation: Violation) -> Reason:
    rule = violation.constraint or violation.kind
    message = violation.message
    if violation.constraint is not None:
        prefix = f"constraint {violation.constraint!r} violated: "
        message = message.removeprefix(prefix)
    return Reason(rule, violation.kind, violation.span, message)


def _no_repair(part: ir.Model, proposal: Proposal, keep: Collection[int], status: str, time_limit: float,
               workers: int) -> NoRepair:
    seconds = f"{to_seconds(proposal.duration):g}"
    if status != "infeasible":
        message = (f"no repair found within the time limit of {time_limit:g} s; this is not a proof that none "
                   "exists (raise --time-limit)")
        return NoRepair([Diagnostic("W401", message, Span(proposal.path))], proven=False)
    mine = restricted(proposal, part)
    items, minimal = _limit_core(part, mine, keep) or keep_core(part, mine, keep, time_limit=time_limit,
                                                                 workers=workers)
    parts = [f"{item.id if item.kind in ('constraint', 'keep') else f'{item.id} [{item.kind}]'} "
             f"({where(item.span)}) {item.text}" for item in items]
    note = "" if minimal else " (time limit reached: the set may not be minimal)"
    kept = any(item.kind == "keep" for item in items)
    head = (f"no timeline of {seconds} s keeps what must be kept" if kept
            else f"no timeline of {seconds} s is consistent with {part.name}")
    message = f"{head}: " + " … ".join(parts) + note
    first = next((item.span for item in items if item.kind == "keep"), None)
    first = first or next((item.span for item in items if item.span.line > 0), Span(proposal.path))
    return NoRepair([Diagnostic(NO_REPAIR, message, first)], items, proven=True, minimal=minimal)


def _limit_core(part: ir.Model, proposal: Proposal, keep: Collection[int]) -> tuple[list[Item], bool] | None:
    """More kept occurrences of one signal than it may have: those and the signal's rule (the
    model has no slot to switch off for them, so say it directly)."""
    from mse.solve.bounds import semantic_limit

    for signal in part.signals:
        mine = [i for i in sorted(keep) if proposal.occurrences[i].signal == signal.id]
        limit = semantic_limit(signal, proposal.duration)
        if len(mine) > limit:
            why = (f"{signal.id} fits no occurrence in {to_seconds(proposal.duration):g} s" if limit == 0 else
                   f"{signal.id} occurs at most {limit} time{'s' if limit > 1 else ''}")
            rule = Item(signal.id, "occurrence rule", signal.span, why)
            kept = [Item(proposal.occurrences[i].name, "keep", proposal.occurrences[i].span,
                         f"kept: {proposal.occurrences[i].describe()}") for i in mine[:limit + 1]]
            return [*kept, rule], True
    return None
