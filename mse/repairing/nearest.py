"""The consistent timeline nearest to a proposal: one CP-SAT model (docs/repair.md).

The timeline's occurrences are the slots of the existing encoding
(:func:`mse.solve.cpsat.encode.build`: every relation, duration rule and exclusive modality
exactly as sampling uses them).  On top of it, each proposed occurrence *i* of signal *s* may
be matched to one slot *j* of *s* (``m[i][j]``; each slot keeps at most one proposal), and

* an unmatched proposal is **dropped**, a present unmatched slot is **added**;
* a matched proposal **moves** ``|start_j - start_i| + |stop_j - stop_i|`` ms, times its weight.

The objective is lexicographic: first the fewest occurrences dropped or added, then the least
weighted time moved, as one sum ``BIG * changes + moved`` with ``BIG`` larger than any move.

**Enough slots.**  Take an optimal repair and remove an added occurrence that neither keeps a
signal present nor witnesses a false relational atom: every atom keeps its value (the
argument of :mod:`mse.solve.bounds`), so the timeline stays consistent and is strictly
cheaper.  So an optimal repair adds at most ``max(1, atoms naming s)`` occurrences of ``s``
beyond the proposed ones, and ``min(semantic limit, proposed + that)`` slots per signal make
CP-SAT's OPTIMAL a proof of optimality among all timelines.

Matches are monotone (the *k*-th kept proposal of a signal takes an earlier slot than the
*k+1*-th): on a line, crossing matches never cost less than uncrossed ones, so this only
removes symmetric solutions.
"""

from __future__ import annotations

import time
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from mse.diagnostics import Span
from mse.ir import model as ir
from mse.repairing.proposal import Proposal
from mse.solve.bounds import atom_mentions, semantic_limit
from mse.solve.cpsat.encode import Encoding, Item, build

if TYPE_CHECKING:
    from ortools.sat.python import cp_model

#: Matching pairs of one signal above which the monotone-order clauses are left out (they only
#: prune symmetric solutions; their number grows with the fourth power of the proposal's size).
MONOTONE_LIMIT = 400


@dataclass(frozen=True, slots=True)
class Placed:
    """One occurrence of the repaired timeline; ``source`` is the index (in the proposal's
    occurrences) of the proposed occurrence it keeps, None when it was added."""

    signal: str
    start: int
    stop: int
    source: int | None


@dataclass(frozen=True)
class Solved:
    """The repaired occurrences, whether CP-SAT proved them optimal, the two parts of the
    objective and the time CP-SAT took (seconds)."""

    placed: tuple[Placed, ...]
    optimal: bool
    changes: int
    moved: int
    seconds: float


@dataclass
class RepairModel:
    """The CP-SAT model of one repair and its handles."""

    enc: Encoding
    match: dict[tuple[int, int], Any]  # (proposal index, slot key) -> literal
    slot_keys: dict[int, tuple[str, int]]  # slot key -> (signal, slot index)
    moved: dict[int, tuple[Any, Any]]  # proposal index -> (start distance, stop distance)
    farthest: dict[int, int]  # proposal index -> the most both distances can add up to
    kept: dict[int, Any]  # proposal index -> "it is matched" literal
    keep_enable: dict[int, Any]  # proposal index -> enable literal of its keep rule (switchable)


def slot_counts(model: ir.Model, proposal: Proposal) -> dict[str, int]:
    """Slots per signal: the proposed occurrences plus what an optimal repair may add."""
    mentions = atom_mentions(model)
    proposed: dict[str, int] = {}
    for occurrence in proposal.known:
        assert occurrence.signal is not None
        proposed[occurrence.signal] = proposed.get(occurrence.signal, 0) + 1
    return {s.id: min(semantic_limit(s, proposal.duration), proposed.get(s.id, 0) + max(1, mentions[s.id]))
            for s in model.signals}


def build_repair(model: ir.Model, proposal: Proposal, keep: Collection[int], *, switchable: bool = False,
                 counts: Mapping[str, int] | None = None) -> RepairModel:
    """The repair model.  ``keep``: indices of proposed occurrences that must not be dropped
    (each one a switchable rule of kind "keep" when ``switchable``)."""
    duration = proposal.duration
    enc = build(model, duration, counts or slot_counts(model, proposal), switchable=switchable)
    cp = enc.cp
    by_signal: dict[str, list[int]] = {}
    for index, occurrence in enumerate(proposal.occurrences):
        if occurrence.signal is not None:
            by_signal.setdefault(occurrence.signal, []).append(index)
    match: dict[tuple[int, int], Any] = {}
    slot_keys: dict[int, tuple[str, int]] = {}
    moved: dict[int, tuple[Any, Any]] = {}
    farthest: dict[int, int] = {}
    kept: dict[int, Any] = {}
    keep_enable: dict[int, Any] = {}
    for signal_id, slots in enc.slots.items():
        for j in range(len(slots)):
            slot_keys[len(slot_keys)] = (signal_id, j)
    key_of = {value: key for key, value in slot_keys.items()}
    for signal_id, indices in by_signal.items():
        slots = enc.slots[signal_id]
        indices.sort(key=lambda i: (proposal.occurrences[i].start, proposal.occurrences[i].stop))
        for i in indices:
            occurrence = proposal.occurrences[i]
            far_start = max(occurrence.start, abs(duration - occurrence.start))
            far_stop = max(occurrence.stop, abs(duration - occurrence.stop))
            start_distance = cp.new_int_var(0, far_start, f"ds{i}")
            stop_distance = cp.new_int_var(0, far_stop, f"de{i}")
            # Where the proposal ends up: the matched slot's edges (its own times when dropped).
            start_at = cp.new_int_var(0, duration, f"s{i}")
            stop_at = cp.new_int_var(0, duration, f"e{i}")
            literals = []
            for j, slot in enumerate(slots):
                literal = cp.new_bool_var(f"m{i}_{j}")
                cp.add_implication(literal, slot.present)
                cp.add(start_at == slot.start).only_enforce_if(literal)
                cp.add(stop_at == slot.stop).only_enforce_if(literal)
                match[(i, key_of[(signal_id, j)])] = literal
                literals.append(literal)
            is_kept = cp.new_bool_var(f"kept{i}")
            cp.add(sum(literals) == is_kept)
            for distance, at, proposed in ((start_distance, start_at, occurrence.start),
                                           (stop_distance, stop_at, occurrence.stop)):
                cp.add(distance >= at - proposed).only_enforce_if(is_kept)
                cp.add(distance >= proposed - at).only_enforce_if(is_kept)
                cp.add(distance == 0).only_enforce_if(~is_kept)
            kept[i] = is_kept
            moved[i] = (start_distance, stop_distance)
            farthest[i] = far_start + far_stop
            if i in keep or occurrence.fixed:
                # Not dropped (and, when fixed, not moved): the proposal's own rules, switchable
                # so that an explanation can name them.
                enforce: list[Any] = []
                if switchable:
                    enable = cp.new_bool_var(f"keep{i}")
                    what = "fixed at" if occurrence.fixed else "kept:"
                    enc.enable[f"keep:{i}"] = enable
                    enc.items[f"keep:{i}"] = Item(occurrence.name, "keep", occurrence.span,
                                                  f"{what} {occurrence.describe()}")
                    keep_enable[i] = enable
                    enforce = [enable]
                cp.add(is_kept == 1).only_enforce_if(enforce)
                if occurrence.fixed:
                    cp.add(start_distance == 0).only_enforce_if(enforce)
                    cp.add(stop_distance == 0).only_enforce_if(enforce)
        for j in range(len(slots)):
            cp.add_at_most_one(match[(i, key_of[(signal_id, j)])] for i in indices)
        # Implied: a dropped proposal and an added slot of one signal never coexist in an
        # optimal repair (matching them saves two changes), so min(proposed, present) match.
        present = [slot.present for slot in slots]
        if present:
            both = cp.new_int_var(0, len(indices), "")
            cp.add_min_equality(both, [len(indices), sum(present)])
            cp.add(sum(kept[i] for i in indices) >= both)
        if len(indices) * len(slots) <= MONOTONE_LIMIT:
            for a, i in enumerate(indices):
                for i2 in indices[a + 1:]:
                    for j in range(len(slots)):
                        for j2 in range(j + 1):
                            cp.add_bool_or([~match[(i, key_of[(signal_id, j)])],
                                            ~match[(i2, key_of[(signal_id, j2)])]])
    _order_exclusive(model, enc)
    return RepairModel(enc, match, slot_keys, moved, farthest, kept, keep_enable)


def _order_exclusive(model: ir.Model, enc: Encoding) -> None:
    """One "which comes first" literal per pair of slots of different signals in an exclusive
    modality (the encoding leaves unrelated pairs to NoOverlap alone).  The rule is the same;
    what changes is the proof: once the search fixes these literals, the linear relaxation
    of the remaining problem (differences of times, distances to the proposal) is exact, so
    the bound on the time moved closes after branching on orders instead of milliseconds."""
    import itertools

    cp = enc.cp
    for modality in sorted(model.exclusive_modalities):
        members = [slot for signal in model.signals if signal.modality == modality
                   for slot in enc.slots[signal.id] if slot.decided]
        for first, second in itertools.combinations(members, 2):
            if first.signal == second.signal:
                continue
            before = cp.new_bool_var("")
            both = [first.present, second.present]
            cp.add(first.stop <= second.start).only_enforce_if([before, *both])
            cp.add(second.stop <= first.start).only_enforce_if([~before, *both])


def objective_parts(repair: RepairModel, proposal: Proposal) -> tuple[Any, Any]:
    """(occurrences dropped or added, weighted ms moved) as linear expressions."""
    present = [slot.present for slots in repair.enc.slots.values() for slot in slots if slot.decided]
    matched = list(repair.kept.values())
    # dropped = proposals - matched; added = present - matched.
    changes = len(matched) - 2 * sum(matched) + sum(present)
    moved = sum(proposal.occurrences[i].weight * (d[0] + d[1]) for i, d in repair.moved.items())
    return changes, moved


def _hint(repair: RepairModel, proposal: Proposal) -> None:
    """The proposal itself, in order, as the search's first guess (CP-SAT repairs it)."""
    cp = repair.enc.cp
    taken: dict[str, int] = {}
    for i in sorted(repair.kept, key=lambda i: proposal.occurrences[i].start):
        occurrence = proposal.occurrences[i]
        assert occurrence.signal is not None
        j = taken.get(occurrence.signal, 0)
        slots = repair.enc.slots[occurrence.signal]
        if j >= len(slots):
            cp.add_hint(repair.kept[i], False)
            continue
        taken[occurrence.signal] = j + 1
        slot = slots[j]
        cp.add_hint(slot.present, True)
        cp.add_hint(slot.start, min(occurrence.start, proposal.duration))
        cp.add_hint(slot.stop, min(occurrence.stop, proposal.duration))
        cp.add_hint(repair.kept[i], True)


def components(model: ir.Model) -> list[ir.Model]:
    """The set cut into independent parts: signals named together by a constraint, or sharing
    an exclusive modality, fall in one part, with the constraints and modalities that concern
    them.  The objective is a sum over occurrences, so the nearest timeline is the union of
    each part's nearest timeline, and a part whose proposed occurrences are already consistent
    keeps them unchanged."""
    parent = {s.id: s.id for s in model.signals}

    def root(name: str) -> str:
        while parent[name] != name:
            parent[name] = parent[parent[name]]
            name = parent[name]
        return name

    def join(names: Collection[str]) -> None:
        names = list(names)
        for other in names[1:]:
            parent[root(other)] = root(names[0])

    for constraint in model.constraints:
        join(sorted(ir.mentioned_signals(constraint.expr)))
    for modality in model.exclusive_modalities:
        join([s.id for s in model.signals if s.modality == modality])
    groups: dict[str, list[ir.Signal]] = {}
    for signal in model.signals:
        groups.setdefault(root(signal.id), []).append(signal)
    parts = []
    for members in groups.values():
        ids = {s.id for s in members}
        constraints = tuple(c for c in model.constraints if ir.mentioned_signals(c.expr) & ids)
        modalities = tuple(m for m in model.modalities if any(s.modality == m.name for s in members))
        parts.append(ir.Model(model.name, tuple(members), constraints, modalities, model.description, model.path))
    loose = tuple(c for c in model.constraints if not ir.mentioned_signals(c.expr))
    if loose:  # constraints naming no signal (only constants and the duration): a part of their own
        parts.append(ir.Model(model.name, (), loose, (), model.description, model.path))
    return parts


def restricted(proposal: Proposal, part: ir.Model) -> Proposal:
    """The proposal's occurrences of ``part``'s signals (indices keep their meaning: the
    others become foreign for this part)."""
    from dataclasses import replace

    ids = part.signal_by_id
    return replace(proposal, occurrences=tuple(
        o if o.signal in ids else replace(o, signal=None) for o in proposal.occurrences))


def solve(model: ir.Model, proposal: Proposal, keep: Collection[int], *, time_limit: float = 10.0,
          workers: int = 1, seed: int = 0) -> tuple[Solved | None, str, ir.Model | None]:
    """The nearest consistent timeline, part by part (:func:`components`): (the repair,
    "optimal" | "feasible"), or (None, "infeasible" | "unknown", the part that has none)."""
    from mse.ir.evaluate import check_schedule

    deadline = time.monotonic() + time_limit
    placed: list[Placed] = []
    optimal, changes, moved, seconds = True, 0, 0, 0.0
    for part in components(model):
        mine = restricted(proposal, part)
        if not check_schedule(part, mine.schedule()):
            placed.extend(Placed(o.signal, o.start, o.stop, i) for i, o in enumerate(mine.occurrences)
                          if o.signal is not None)
            continue
        solved, status = solve_part(part, mine, keep, time_limit=max(0.01, deadline - time.monotonic()),
                                    workers=workers, seed=seed)
        if solved is None:
            return None, status, part
        placed.extend(solved.placed)
        optimal &= solved.optimal
        changes += solved.changes
        moved += solved.moved
        seconds += solved.seconds
    placed.sort(key=lambda p: (p.start, p.signal, p.stop))
    return Solved(tuple(placed), optimal, changes, moved, seconds), ("optimal" if optimal else "feasible"), None




def solve_part(model: ir.Model, proposal: Proposal, keep: Collection[int], *, time_limit: float = 10.0,
               workers: int = 1, seed: int = 0) -> tuple[Solved | None, str]:
    """(the repair, "optimal" | "feasible"), or (None, "infeasible" | "unknown").

    First the common case: nothing dropped or added, the proposed occurrences only moved (a
    model with exactly the proposed slots).  When that has no solution, the full model, in two
    searches: the fewest changes, then, with that many, the least time moved (each search
    starting from the previous answer)."""
    from ortools.sat.python import cp_model

    deadline = time.monotonic() + time_limit
    began = time.perf_counter()
    proposed = _proposed_counts(proposal)
    limits = slot_counts(model, proposal)
    if all(count <= limits[name] for name, count in proposed.items()):
        slim = build_repair(model, proposal, keep, counts={s.id: proposed.get(s.id, 0) for s in model.signals})
        changes, moved = objective_parts(slim, proposal)
        slim.enc.cp.add(changes == 0)
        slim.enc.cp.minimize(moved)
        _hint(slim, proposal)
        status, solver = _search(slim.enc.cp, deadline, workers, seed, MOVE_SEARCHES)
        if status in (cp_model.OPTIMAL, cp_model.FEASIBLE):
            return _solved(slim, solver, status == cp_model.OPTIMAL, changes, moved, began)
        if status != cp_model.INFEASIBLE:
            return None, "unknown"
    repair = build_repair(model, proposal, keep)
    changes, moved = objective_parts(repair, proposal)
    cp = repair.enc.cp
    _hint(repair, proposal)
    cp.minimize(changes)
    status, solver = _search(cp, deadline, workers, seed, CHANGE_SEARCHES)
    if status == cp_model.INFEASIBLE:
        return None, "infeasible"
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return None, "unknown"
    optimal = status == cp_model.OPTIMAL
    fewest = round(solver.objective_value)
    _hint_solution(cp, solver)
    cp.add(changes == fewest) if optimal else cp.add(changes <= fewest)
    cp.minimize(moved)
    second, better = _search(cp, deadline, workers, seed, MOVE_SEARCHES)
    if second in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return _solved(repair, better, optimal and second == cp_model.OPTIMAL, changes, moved, began)
    return _solved(repair, solver, False, changes, moved, began)


def _proposed_counts(proposal: Proposal) -> dict[str, int]:
    counts: dict[str, int] = {}
    for occurrence in proposal.known:
        assert occurrence.signal is not None
        counts[occurrence.signal] = counts.get(occurrence.signal, 0) + 1
    return counts


def _solved(repair: RepairModel, solver: cp_model.CpSolver, optimal: bool, changes: Any, moved: Any,
            began: float) -> tuple[Solved, str]:
    solved = Solved(_decode(repair, solver), optimal, round(solver.value(changes)), round(solver.value(moved)),
                    time.perf_counter() - began)
    return solved, "optimal" if optimal else "feasible"


#: The searches tried in turn, each until it proves its answer or spends its deterministic time
#: (the last one: the rest of the time limit).  Counting changes: a light search (no presolve,
#: no linear relaxation) usually finds and proves the count at once; the default one settles
#: the rest.  Minimizing the time moved: the full linear relaxation (level 2), which with the
#: order literals of the exclusive modalities proves the bound after branching on orders.
#: Measured in bench/evaluation/repair.py.
CHANGE_SEARCHES: list[dict[str, Any]] = [{"light": True, "max_deterministic_time": 0.03},
                                         {"linearization_level": 2}]
MOVE_SEARCHES: list[dict[str, Any]] = [{"linearization_level": 2}]


def _search(cp: cp_model.CpModel, deadline: float, workers: int, seed: int,
            searches: Sequence[Mapping[str, Any]]) -> tuple[Any, cp_model.CpSolver]:
    from ortools.sat.python import cp_model

    from mse.solve.cpsat.engine import make_solver

    for number, settings in enumerate(searches):
        options = dict(settings)
        light = bool(options.pop("light", False))
        solver = make_solver(max(0.01, deadline - time.monotonic()), workers, seed, light=light)
        for key, value in options.items():
            setattr(solver.parameters, key, value)
        if number == len(searches) - 1:
            solver.parameters.max_deterministic_time = float("inf")
        status = solver.solve(cp)
        if status in (cp_model.OPTIMAL, cp_model.INFEASIBLE):
            break
    return status, solver


def _hint_solution(cp: cp_model.CpModel, solver: cp_model.CpSolver) -> None:
    """Every variable's value in ``solver``'s solution as the next search's hint."""
    cp.clear_hints()  # type: ignore[no-untyped-call]
    proto = cp.proto
    for index in range(len(proto.variables)):
        cp.proto.solution_hint.vars.append(index)
        cp.proto.solution_hint.values.append(solver.response_proto.solution[index])


def _decode(repair: RepairModel, solver: cp_model.CpSolver) -> tuple[Placed, ...]:
    source: dict[tuple[str, int], int] = {}
    for (i, key), literal in repair.match.items():
        if solver.boolean_value(literal):
            source[repair.slot_keys[key]] = i
    placed = []
    for signal_id, slots in repair.enc.slots.items():
        for j, slot in enumerate(slots):
            if slot.decided and solver.boolean_value(slot.present):
                placed.append(Placed(signal_id, solver.value(slot.start), solver.value(slot.stop),
                                     source.get((signal_id, j))))
    return tuple(sorted(placed, key=lambda p: (p.start, p.signal, p.stop)))


def keep_core(model: ir.Model, proposal: Proposal, keep: Collection[int], *,
              time_limit: float = 10.0, workers: int = 1) -> tuple[list[Item], bool]:
    """A minimal set of rules (the set's and the kept occurrences) that no timeline satisfies
    together, when no repair keeps ``keep``; and whether it is proven minimal (False when a
    shrinking step ran out of time).  Deletion-based, as :mod:`mse.solve.cpsat.explain`."""
    from ortools.sat.python import cp_model

    from mse.solve.cpsat.engine import make_solver

    deadline = time.monotonic() + time_limit
    counts = {name: max(1, count) for name, count in slot_counts(model, proposal).items()}
    repair = build_repair(model, proposal, keep, switchable=True, counts=counts)
    enc = repair.enc
    everything = list(enc.enable)

    def status_of(keys: list[str]) -> tuple[str, list[str]]:
        enc.cp.clear_assumptions()
        enc.cp.add_assumptions([enc.enable[k] for k in keys])
        solver = make_solver(max(0.01, deadline - time.monotonic()), workers)
        status = solver.solve(enc.cp)
        if status in (cp_model.OPTIMAL, cp_model.FEASIBLE):
            return "feasible", []
        if status != cp_model.INFEASIBLE:
            return "unknown", []
        by_index = {enc.enable[k].index: k for k in keys}
        core = [by_index[i] for i in solver.sufficient_assumptions_for_infeasibility() if i in by_index]
        return "infeasible", core or keys

    status, core = status_of(everything)
    if status != "infeasible":
        return [], False
    minimal = True
    # Blame the set's rules last: the kept occurrences are tried for deletion after them.
    current = sorted(core, key=lambda k: (k.startswith("constraint:"), k.startswith("keep:"), everything.index(k)))
    for key in list(current):
        if key not in current:
            continue
        if deadline - time.monotonic() <= 0.01:
            minimal = False
            break
        trial = [k for k in current if k != key]
        status, smaller = status_of(trial)
        if status == "infeasible":
            current = [k for k in trial if k in set(smaller)]
        elif status == "unknown":
            minimal = False
    return [enc.items[k] for k in sorted(current, key=everything.index)], minimal


def where(span: Span) -> str:
    """``file:line`` of a span (just the file when it has no line)."""
    return f"{span.path}:{span.line}" if span.line > 0 else span.path
