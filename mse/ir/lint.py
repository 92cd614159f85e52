"""Static lint rules (W3xx): a tuple of pure functions from a model to diagnostics.

Callers may pass their own tuple; solver-backed rules (W4xx) live in ``mse.solve``.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Collection, Iterable, Iterator

from mse.diagnostics import Diagnostic
from mse.ir import model as ir
from mse.ir.printer import expr_text, term_text
from mse.ir.relations import RELATIONS, is_symmetric

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
)


def lint_model(model: ir.Model, rules: tuple[Rule, ...] = STATIC_RULES) -> list[Diagnostic]:
    found: list[Diagnostic] = []
    for rule in rules:
        found.extend(rule(model))
    return sorted(found, key=Diagnostic.sort_key)
