"""What a rolling horizon remembers of the committed part of a timeline.

A long timeline is decided window by window (:mod:`mse.solve.cpsat.solver`); each window's
model must know enough of the committed occurrences to keep every constraint right, yet
stay as small as the first window's.  Per signal it keeps the *first* and the *last*
committed occurrence, and per relational atom whether committed occurrences already make
it false.  That is enough:

* an atom is false iff some combination of occurrences breaks it.  For ``includes``,
  ``precedes``, ``rightincludes`` and the comparisons (``<``, ``<=``, ``>``, ``>=``, ``=``
  with a tolerance) the relation is a conjunction of "edge minus edge <= constant", and
  some combination breaks one of them iff the extreme edges do: occurrences of one signal
  are ordered and disjoint, so the first has the smallest start and stop and the last the
  largest.  A comparison of one signal with itself or a constant is decided per
  occurrence, when that occurrence is committed.
* ``excludes`` breaks iff two occurrences overlap: a new occurrence starts after the
  window's beginning, where every committed occurrence but a signal's last has ended.

So when a window is committed, each atom naming a signal with new occurrences is evaluated
once on the previous representatives plus the new occurrences (:meth:`Committed.commit`),
and the representatives become the first and last of both.  Memory and work per window
stay constant whatever the elapsed time.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping

from mse.ir import model as ir
from mse.ir.evaluate import evaluate_atom
from mse.ir.schedule import Occurrence


def relational_atoms(model: ir.Model) -> list[ir.Relation | ir.Compare]:
    found: dict[ir.Relation | ir.Compare, None] = {}
    for constraint in model.constraints:
        for node in ir.walk(constraint.expr):
            if isinstance(node, ir.Relation | ir.Compare) and ir.atom_signals(node):
                found.setdefault(node)
    return list(found)


class Committed:
    """The committed prefix of a timeline, summarised."""

    def __init__(self, model: ir.Model, duration: int) -> None:
        self.duration = duration
        self.first: dict[str, tuple[int, int]] = {}
        self.last: dict[str, tuple[int, int]] = {}
        self.counts: Counter[str] = Counter()
        self.falsified: set[ir.Atom] = set()
        self._atoms_of: dict[str, list[ir.Relation | ir.Compare]] = {}
        for atom in relational_atoms(model):
            for name in set(ir.atom_signals(atom)):
                self._atoms_of.setdefault(name, []).append(atom)

    def representatives(self) -> dict[str, tuple[tuple[int, int], ...]]:
        found: dict[str, tuple[tuple[int, int], ...]] = {}
        for name, first in self.first.items():
            last = self.last[name]
            found[name] = (first,) if first == last else (first, last)
        return found

    def free_from(self) -> Mapping[str, int]:
        """Per signal, when its last committed occurrence stops."""
        return {name: stop for name, (_, stop) in self.last.items()}

    def commit(self, occurrences: Iterable[Occurrence]) -> None:
        new: dict[str, list[tuple[int, int]]] = {}
        for occurrence in sorted(occurrences):
            new.setdefault(occurrence.signal, []).append((occurrence.start, occurrence.stop))
        if not new:
            return
        intervals = {name: list(reps) for name, reps in self.representatives().items()}
        for name, added in new.items():
            intervals.setdefault(name, []).extend(added)
        touched = {atom for name in new for atom in self._atoms_of.get(name, ())}
        for atom in touched - self.falsified:
            if evaluate_atom(atom, intervals, self.duration) is False:
                self.falsified.add(atom)
        for name, added in new.items():
            self.first.setdefault(name, added[0])
            self.last[name] = added[-1]
            self.counts[name] += len(added)
