"""Static lint rules (W3xx): a tuple of pure functions from a model to diagnostics.

Callers may pass their own tuple; solver-backed rules (W4xx) live in ``mse.solve``.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping

from mse.diagnostics import Diagnostic
from mse.ir import model as ir
from mse.ir.printer import expr_text, term_text
from mse.ir.relations import COMPARISONS, RELATIONS, is_conjunction, is_symmetric
from mse.ir.schedule import to_seconds, to_ticks

#: Lexeme classes (the part before '=') and the modality each one belongs to.
LEXEME_CLASS_MODALITY: dict[str, str] = {
    "faceexp": "face",
    "face": "face",
    "head": "head",
    "gaze": "gaze",
    "torso": "torso",
    "posture": "torso",
    "gesture": "gesture",
    "adjectival": "gesture",
    "deictic": "gesture",
    "performative": "gesture",
    "beat": "gesture",
    "iconic": "gesture",
    "metaphoric": "gesture",
    "rest": "gesture",
    "emotion": "gesture",
    "hand_shape": "gesture",
    "speech": "speech",
}
#: Modalities treated as one family by the lexeme rule.
_MODALITY_FAMILY = {"posture": "torso"}

Rule = Callable[[ir.Model], Iterable[Diagnostic]]


def inactive_signals(model: ir.Model) -> Iterator[Diagnostic]:
    for signal in model.signals:
        if signal.probability_start == 0 and signal.probability_end == 0:
            yield Diagnostic(
                "W301", f"signal {signal.id!r} is inactive: probability_start and probability_end are 0", signal.span
            )


def self_relations(model: ir.Model) -> Iterator[Diagnostic]:
    for constraint in model.constraints:
        for node in ir.walk(constraint.expr):
            same = False
            if isinstance(node, ir.Relation):
                same = node.left == node.right
            elif isinstance(node, ir.Compare):
                same = (
                    isinstance(node.left, ir.SignalTime)
                    and isinstance(node.right, ir.SignalTime)
                    and node.left.signal == node.right.signal
                    and node.left.edge == node.right.edge
                )
            if same:
                yield Diagnostic(
                    "W303", f"constraint {constraint.id!r} relates a signal with itself: {expr_text(node)}", node.span
                )


def _never_occurring(model: ir.Model) -> set[str]:
    never = {s.id for s in model.signals if s.probability_start == 0 and s.probability_end == 0}
    for constraint in model.constraints:
        expr = constraint.expr
        if isinstance(expr, ir.Not) and isinstance(expr.operand, ir.Exists):
            never.add(expr.operand.signal)
    return never


def unreachable_constraints(model: ir.Model) -> Iterator[Diagnostic]:
    never = _never_occurring(model)
    for constraint in model.constraints:
        triggers = constraint.triggers
        if triggers and triggers <= never:
            names = ", ".join(sorted(triggers))
            yield Diagnostic(
                "W304", f"constraint {constraint.id!r} is never instantiated: {names} can never occur", constraint.span
            )


def normalise(expr: ir.Expr) -> ir.Expr:
    """A canonical form for comparing constraints: commutative operands sorted, ``>`` as ``<``."""
    if isinstance(expr, ir.Not):
        return ir.Not(normalise(expr.operand))
    if isinstance(expr, ir.Implies):
        return ir.Implies(normalise(expr.left), normalise(expr.right))
    if isinstance(expr, ir.And | ir.Or):
        normalised = {expr_text(n): n for n in (normalise(o) for o in expr.operands)}
        return type(expr)(tuple(normalised[text] for text in sorted(normalised)))
    if isinstance(expr, ir.Relation) and is_symmetric(RELATIONS[expr.kind]) and expr.left > expr.right:
        return ir.Relation(expr.kind, expr.right, expr.left)
    if isinstance(expr, ir.Compare):
        flipped = {">": "<", ">=": "<="}
        if expr.op in flipped:
            return ir.Compare(flipped[expr.op], expr.right, expr.left, expr.tolerance)  # type: ignore[arg-type]
        if expr.op == "=":
            left, right = sorted((expr.left, expr.right), key=repr)
            return ir.Compare("=", left, right, expr.tolerance)
    return expr


def duplicate_constraints(model: ir.Model) -> Iterator[Diagnostic]:
    seen: dict[ir.Expr, ir.Constraint] = {}
    for constraint in model.constraints:
        key = normalise(constraint.expr)
        first = seen.get(key)
        if first is not None:
            yield Diagnostic(
                "W305", f"constraint {constraint.id!r} repeats {first.id!r} (line {first.span.line})", constraint.span
            )
        else:
            seen[key] = constraint


def lexeme_modality(model: ir.Model) -> Iterator[Diagnostic]:
    for signal in model.signals:
        if "=" not in signal.lexeme:
            continue
        lexeme_class = signal.lexeme.split("=", 1)[0].strip().lower()
        expected = LEXEME_CLASS_MODALITY.get(lexeme_class)
        modality = _MODALITY_FAMILY.get(signal.modality, signal.modality)
        if expected is not None and signal.modality in ir.KNOWN_MODALITIES and expected != modality:
            yield Diagnostic(
                "W306",
                f"signal {signal.id!r} has a {lexeme_class}= lexeme ({expected}) but modality {signal.modality!r}",
                signal.span,
            )


def unknown_modalities(model: ir.Model) -> Iterator[Diagnostic]:
    known = ", ".join(sorted(ir.KNOWN_MODALITIES))
    for signal in model.signals:
        if signal.modality not in ir.KNOWN_MODALITIES:
            yield Diagnostic(
                "W307", f"signal {signal.id!r} has unknown modality {signal.modality!r} (known: {known})", signal.span
            )


def max_occurrences_without_repetition(model: ir.Model) -> Iterator[Diagnostic]:
    for signal in model.signals:
        if signal.max_occurrences is not None and signal.repetitivity != 1:
            yield Diagnostic(
                "W311",
                f"signal {signal.id!r} sets max_occurrences={signal.max_occurrences} but not "
                'repetitivity="1": it occurs at most once, so max_occurrences has no effect',
                signal.span,
            )


def unused_exclusive_modalities(model: ir.Model) -> Iterator[Diagnostic]:
    used = {signal.modality for signal in model.signals}
    for modality in model.modalities:
        if modality.exclusive and modality.name not in used:
            yield Diagnostic(
                "W312",
                f"modality {modality.name!r} is declared exclusive but no signal uses it (a misspelling?)",
                modality.span,
            )


def unknown_motion_actions(known: Collection[str]) -> Rule:
    """A rule flagging motion leaves whose action is not in ``known`` (the starter library's
    actions: without a ``--library`` that has them, ``animate`` fails on those leaves)."""
    names = frozenset(known)
    listed = ", ".join(sorted(names))

    def rule(model: ir.Model) -> Iterator[Diagnostic]:
        for signal in model.signals:
            leaf = signal.motion
            if leaf is not None and leaf.action not in names:
                guess = difflib.get_close_matches(leaf.action, sorted(names), n=1)
                hint = f" (did you mean {guess[0]!r}?)" if guess else ""
                yield Diagnostic(
                    "W310",
                    f"motion action {leaf.action!r} of signal {signal.id!r} is unknown to the starter "
                    f"library{hint}; animating it needs a --library that has it (starter: {listed})",
                    leaf.span,
                )

    return rule


def speech_anchored(model: ir.Model) -> Iterator[Diagnostic]:
    """A note, not a warning: a set written for talking agents is right to use its speech;
    lint has no request, so it can only say what sampling and checking will need."""
    for constraint in model.constraints:
        for node in ir.walk(constraint.expr):
            if isinstance(node, ir.Compare):
                term = node.left if isinstance(node.left, ir.SpeechTime) else node.right
                if isinstance(term, ir.SpeechTime):
                    yield Diagnostic(
                        "N313",
                        f"constraint {constraint.id!r} refers to the agent's speech ({term_text(term)}): "
                        "sampling and checking it need speech (--speech FILE, or a timeline's 'utterances'); "
                        "solver-backed lint leaves it out",
                        term.span if term.span.line > 0 else constraint.span,
                    )
                    break


# -- W314: a relation that lets one occurrence of a repetitive signal block its later ones --
#: Nodes of the difference system of :func:`_two_fit`: one occurrence of the partner, two of
#: the repetitive signal.
_PARTNER, _FIRST, _SECOND = 0, 2, 4
#: A difference bound ``x - y <= k`` between (signal side, edge) pairs: side 0 the partner,
#: side 1 the repetitive signal; k in ms.
_PairBound = tuple[tuple[int, str], tuple[int, str], int]


def _required_atoms(expr: ir.Expr) -> Iterator[tuple[ir.Relation | ir.Compare, frozenset[str]]]:
    """Relational atoms that must hold whenever their signals and the given ones occur: the
    operands of a top-level conjunction, and the consequent of ``exists(...) implies ...``
    (with the signals the antecedent needs)."""
    if isinstance(expr, ir.And):
        for operand in expr.operands:
            yield from _required_atoms(operand)
    elif isinstance(expr, ir.Relation | ir.Compare):
        yield expr, frozenset()
    elif isinstance(expr, ir.Implies):
        needed = _exists_conjunction(expr.left)
        if needed is not None:
            for atom, more in _required_atoms(expr.right):
                yield atom, more | needed


def _exists_conjunction(expr: ir.Expr) -> frozenset[str] | None:
    if isinstance(expr, ir.Exists):
        return frozenset((expr.signal,))
    if isinstance(expr, ir.And):
        parts = [_exists_conjunction(o) for o in expr.operands]
        if all(p is not None for p in parts):
            return frozenset().union(*(p for p in parts if p is not None))
    return None


def _atom_bounds(atom: ir.Relation | ir.Compare, repetitive: str, partner: str) -> list[_PairBound] | None:
    """The atom as bounds between the two signals' edges, or None when it is not a
    conjunction of such bounds (a disjunction, a constant, the duration, a length)."""
    side = {partner: 0, repetitive: 1}
    if isinstance(atom, ir.Relation):
        meaning = RELATIONS[atom.kind]
        if not is_conjunction(meaning) or {atom.left, atom.right} != {repetitive, partner}:
            return None
        names = {"left": atom.left, "right": atom.right}
        return [((side[names[b.lower.side]], b.lower.edge), (side[names[b.upper.side]], b.upper.edge),
                 b.limit(0)) for b in meaning.bounds]
    terms = {"left": atom.left, "right": atom.right}
    if not all(isinstance(t, ir.SignalTime) for t in terms.values()):
        return None
    times = {k: t for k, t in terms.items() if isinstance(t, ir.SignalTime)}
    if {t.signal for t in times.values()} != {repetitive, partner}:
        return None
    found: list[_PairBound] = []
    for bound in COMPARISONS[atom.op].bounds:
        x, y = times[bound.lower], times[bound.upper]
        # x.edge + x.offset - (y.edge + y.offset) <= k
        found.append(((side[x.signal], x.edge), (side[y.signal], y.edge),
                      bound.limit(atom.tolerance) - x.offset + y.offset))
    return found


def _consistent(size: int, edges: list[tuple[int, int, int]]) -> bool:
    """Does the system of ``x - y <= k`` (edges ``(y, x, k)``) have a solution (no negative cycle)?"""
    infinity = float("inf")
    dist = [[0.0 if i == j else infinity for j in range(size)] for i in range(size)]
    for y, x, k in edges:
        dist[y][x] = min(dist[y][x], k)
    for middle in range(size):
        for i in range(size):
            for j in range(size):
                if dist[i][middle] + dist[middle][j] < dist[i][j]:
                    dist[i][j] = dist[i][middle] + dist[middle][j]
    return all(dist[i][i] >= 0 for i in range(size))


def _two_fit(bounds: list[_PairBound], partner: ir.Signal, repetitive: ir.Signal, count: int) -> bool:
    """Can ``count`` (1 or 2) occurrences of ``repetitive`` satisfy ``bounds`` with one
    occurrence of ``partner`` (durations respected, the two one after the other)?"""
    edges: list[tuple[int, int, int]] = []

    def length(node: int, signal: ir.Signal) -> None:  # stop - start in [min, max]
        edges.append((node + 1, node, -to_ticks(signal.min_duration)))  # start - stop <= -min
        if signal.max_duration is not None:
            edges.append((node, node + 1, to_ticks(signal.max_duration)))  # stop - start <= max

    length(_PARTNER, partner)
    occurrences = [_FIRST, _SECOND][:count]
    for node in occurrences:
        length(node, repetitive)
        for (x_side, x_edge), (y_side, y_edge), k in bounds:
            x = (node if x_side else _PARTNER) + (x_edge == "stop")
            y = (node if y_side else _PARTNER) + (y_edge == "stop")
            edges.append((y, x, k))
    if count == 2:
        edges.append((_SECOND, _FIRST + 1, 0))  # stop of the first <= start of the second
    return _consistent(2 + 2 * count, edges)


def blocking_relations(model: ir.Model) -> Iterator[Diagnostic]:
    """W314: under "every pair of occurrences", a relation that keeps every occurrence of a
    repetitive signal in a window around each occurrence of another signal too narrow for two
    of them lets the first block all later ones once the other signal occurs."""
    signals = model.signal_by_id
    for constraint in model.constraints:
        pairs: dict[tuple[str, str], list[ir.Relation | ir.Compare]] = {}
        for atom, needed in _required_atoms(constraint.expr):
            named = ir.mentioned_signals(atom)
            if len(named) == 2 and needed <= named and named <= signals.keys():
                pairs.setdefault(tuple(sorted(named)), []).append(atom)  # type: ignore[arg-type]
        for pair, atoms in pairs.items():
            blocked = []
            for repetitive in pair:
                signal = signals[repetitive]
                (partner,) = set(pair) - {repetitive}
                bounds = [b for atom in atoms for b in _atom_bounds(atom, repetitive, partner) or []]
                if (signal.repetitivity == 1 and signal.max_occurrences != 1 and bounds
                        and _two_fit(bounds, signals[partner], signal, 1)
                        and not _two_fit(bounds, signals[partner], signal, 2)):
                    blocked.append((repetitive, partner))
            if blocked:
                yield _blocking(constraint, atoms, blocked, signals)


def _blocking(constraint: ir.Constraint, atoms: list[ir.Relation | ir.Compare], blocked: list[tuple[str, str]],
              signals: Mapping[str, ir.Signal]) -> Diagnostic:
    text = " and ".join(expr_text(a) for a in atoms)
    facts = "; ".join(
        f"once {partner!r} occurs, at most one {repetitive!r} can (two of at least "
        f"{to_seconds(to_ticks(signals[repetitive].min_duration)):g} s never both satisfy it with one {partner!r})"
        for repetitive, partner in blocked)
    meant = " and ".join(f"each {repetitive!r} with its nearest {partner!r}" for repetitive, partner in blocked)
    once = ", ".join(repr(r) for r, _ in blocked)
    return Diagnostic(
        "W314",
        f"constraint {constraint.id!r}: {text} holds for every pair of occurrences, so {facts}: the first blocks "
        f"all later ones, although repetitive. Probably meant: {meant}, which a relation cannot say; "
        f'make {once} once-only (repetitivity="0") or widen the relation',
        atoms[0].span if atoms[0].span.line > 0 else constraint.span,
    )


STATIC_RULES: tuple[Rule, ...] = (
    inactive_signals,
    self_relations,
    unreachable_constraints,
    duplicate_constraints,
    lexeme_modality,
    unknown_modalities,
    max_occurrences_without_repetition,
    unused_exclusive_modalities,
    speech_anchored,
    blocking_relations,
)


def lint_model(model: ir.Model, rules: tuple[Rule, ...] = STATIC_RULES) -> list[Diagnostic]:
    found: list[Diagnostic] = []
    for rule in rules:
        found.extend(rule(model))
    return sorted(found, key=Diagnostic.sort_key)
