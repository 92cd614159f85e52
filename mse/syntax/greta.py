"""Importing Greta's MSE behaviour sets as native MSE files.

Two inputs are understood:

- ``lexicon.xml`` (``<behaviorset name="emotion-X" type="mse">``: the signals, plus
  ``<rules>``/``<core>`` for a few sets) with ``constraint.xml`` (``<multimodal
  emotion="X">``: one ``<con>`` tree per constraint);
- the legacy all-in-one ``example.xml`` (``<multimodal emotion="XS">`` holding both).

Each emotion becomes one complete native file (:class:`ImportedExpression`).  The mapping,
and every approximation, is documented in ``docs/greta.md``; approximations and name
repairs are reported as W501/W502 warnings at their Greta position, errors raise
:class:`~mse.diagnostics.MseError` with every problem found.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from pathlib import Path

from lxml import etree

from mse.diagnostics import Diagnostic, MseError, Span
from mse.syntax import greta_read as gr
from mse.syntax import greta_write as gw
from mse.syntax.greta_expr import (
    FALSE,
    GConst,
    GExists,
    GExpr,
    GNot,
    flatten,
    has_constant,
    render,
    simplify,
    triggers_of,
)

#: Greta's emotion names that the paper calls differently (mentioned in the description).
PAPER_NAMES = {"joy": "cheerfulness"}


@dataclass(frozen=True, slots=True)
class ImportedExpression:
    """One Greta emotion as a complete native-format file."""

    name: str
    xml: str
    diagnostics: tuple[Diagnostic, ...]
    signal_count: int = 0
    constraint_count: int = 0


@dataclass(frozen=True, slots=True)
class GretaImport:
    """Every imported expression plus the notes that belong to none of them."""

    expressions: tuple[ImportedExpression, ...]
    diagnostics: tuple[Diagnostic, ...]  # all warnings, sorted (those of expressions too)


# -- public API ----------------------------------------------------------------------------
def import_greta(lexicon_path: str | Path, constraint_path: str | Path) -> list[ImportedExpression]:
    """Every ``emotion-X`` MSE behaviour set of ``lexicon_path`` with its constraints."""
    return list(import_greta_report(lexicon_path, constraint_path).expressions)


def import_greta_legacy(example_path: str | Path) -> list[ImportedExpression]:
    """Every ``<multimodal>`` of the legacy all-in-one ``example.xml``."""
    return list(import_greta_legacy_report(example_path).expressions)


def import_greta_report(lexicon_path: str | Path, constraint_path: str | Path) -> GretaImport:
    lexicon = gr.load(lexicon_path)
    constraints = gr.load(constraint_path)
    errors: list[Diagnostic] = []
    _expect_root(lexicon, "behaviorsets", errors)
    _expect_root(constraints, "multimodals", errors)
    if lexicon.root.tag == "multimodals" and constraints.root.tag == "behaviorsets":
        errors = [Diagnostic(d.code, f"{d.message} (LEXICON and CONSTRAINT swapped?)", d.span)
                  for d in errors]
    if errors:
        raise MseError(errors)
    sets = [
        (str(bs.get("name"))[len("emotion-"):], bs)
        for bs in gr.elements(lexicon.root, "behaviorset")
        if bs.get("type") == "mse" and (bs.get("name") or "").startswith("emotion-")
    ]
    multimodals = [(str(mm.get("emotion") or ""), mm) for mm in gr.elements(constraints.root,
                                                                                "multimodal")]
    loose: list[Diagnostic] = []
    pairs = _match(lexicon, sets, constraints, multimodals, loose)
    expressions: list[ImportedExpression] = []
    taken: set[str] = set()
    for set_name, behaviour_set, multimodal, notes in pairs:
        where = (constraints.attribute_span(multimodal, "emotion") if multimodal is not None
                 else lexicon.attribute_span(behaviour_set, "name"))
        raw = str(multimodal.get("emotion")) if multimodal is not None else set_name
        name = _emotion_name(raw, taken, where, notes)
        signals_parent = _first(behaviour_set, "signals")
        cons = gr.elements(multimodal, "con") if multimodal is not None else []
        sources = f"behaviour set 'emotion-{set_name}' of {lexicon.name}" + (
            f" and the constraints of multimodal emotion '{multimodal.get('emotion')}' of "
            f"{constraints.name}" if multimodal is not None
            else f" (no constraints for it in {constraints.name})")
        expressions.append(_build(
            name, sources, lexicon, signals_parent, gr.LEXICON_ATTRIBUTES, "modality",
            constraints, cons, _first(behaviour_set, "constraints"), notes, errors))
    if errors:
        raise MseError(errors)
    return _report(expressions, loose)


def import_greta_legacy_report(example_path: str | Path) -> GretaImport:
    example = gr.load(example_path)
    errors: list[Diagnostic] = []
    _expect_root(example, "multimodals", errors)
    if errors:
        raise MseError(errors)
    expressions: list[ImportedExpression] = []
    taken: set[str] = set()
    for multimodal in gr.elements(example.root, "multimodal"):
        emotion = multimodal.get("emotion") or ""
        notes: list[Diagnostic] = []
        base = emotion[:-1] if len(emotion) > 1 and emotion.endswith("S") else emotion
        if base != emotion:  # legacy names carry a trailing "S" (embarrassmentS)
            notes.append(Diagnostic(
                "W501", f"legacy emotion '{emotion}' imported as '{base}'",
                example.attribute_span(multimodal, "emotion")))
        name = _emotion_name(base, taken, example.attribute_span(multimodal, "emotion"), notes)
        holders = [multimodal, *gr.elements(multimodal, "cons")]
        cons = [con for holder in holders for con in gr.elements(holder, "con")]
        sources = f"multimodal emotion '{emotion}' of the legacy {example.name}"
        expressions.append(_build(
            name, sources, example, _first(multimodal, "signals"), gr.LEGACY_ATTRIBUTES, "type",
            example, cons, None, notes, errors))
    if errors:
        raise MseError(errors)
    return _report(expressions, [])


def _emotion_name(raw: str, taken: set[str], where: Span, notes: list[Diagnostic]) -> str:
    """An identifier for the expression (and file) name; any change is a W501 note."""
    name = gw.unique_name(gw.identifier(raw), taken)
    if name != raw:
        notes.append(Diagnostic("W501", f"emotion name {raw!r} written as '{name}'", where))
    return name


# -- matching lexicon sets with constraint groups -------------------------------------------
_Pair = tuple[str, etree._Element, etree._Element | None, list[Diagnostic]]


def _match(
    lexicon: gr.GretaFile,
    sets: list[tuple[str, etree._Element]],
    constraints: gr.GretaFile,
    multimodals: list[tuple[str, etree._Element]],
    loose: list[Diagnostic],
) -> list[_Pair]:
    """Pair ``emotion-X`` with ``<multimodal emotion="X">``; near misses are warned (W501)."""
    by_name: dict[str, etree._Element] = {}
    for emotion, element in multimodals:
        if emotion in by_name:
            loose.append(Diagnostic("W501", f"second <multimodal emotion=\"{emotion}\"> ignored",
                                    constraints.span(element)))
        else:
            by_name[emotion] = element
    unused = dict(by_name)
    pairs: list[_Pair] = []
    for set_name, element in sets:
        notes: list[Diagnostic] = []
        found = unused.pop(set_name, None)
        pairs.append((set_name, element, found, notes))
    for index, (set_name, element, found, notes) in enumerate(pairs):
        if found is not None:
            continue
        candidates = [e for e in unused if _similar(set_name, e)]
        where = lexicon.attribute_span(element, "name")
        if len(candidates) == 1:
            emotion = candidates[0]
            match = unused.pop(emotion)
            line = constraints.span(match).line
            notes.append(Diagnostic(
                "W501", f"behaviour set 'emotion-{set_name}' paired with <multimodal "
                f"emotion=\"{emotion}\"> ({constraints.name}:{line}); imported as '{emotion}'",
                where))
            pairs[index] = (set_name, element, match, notes)
        else:
            notes.append(Diagnostic(
                "W501", f"no <multimodal emotion=\"{set_name}\"> in {constraints.name}"
                + (f" (ambiguous: {', '.join(sorted(candidates))})" if candidates else "")
                + "; imported without constraints", where))
    for emotion, element in unused.items():
        loose.append(Diagnostic(
            "W501", f"<multimodal emotion=\"{emotion}\"> has no behaviour set "
            f"'emotion-{emotion}' in {lexicon.name}; its constraints are skipped",
            constraints.span(element)))
    return pairs


def _similar(set_name: str, emotion: str) -> bool:
    a, b = set_name.lower(), emotion.lower()
    if a == b or a.startswith(b) or b.startswith(a):
        return bool(a and b)
    return difflib.SequenceMatcher(None, a, b).ratio() >= 0.85


# -- building one expression ----------------------------------------------------------------
def _build(
    name: str,
    sources: str,
    signal_file: gr.GretaFile,
    signals_parent: etree._Element | None,
    attribute_map: dict[str, str],
    modality_attribute: str,
    con_file: gr.GretaFile,
    cons: list[etree._Element],
    lexicon_constraints: etree._Element | None,
    notes: list[Diagnostic],
    errors: list[Diagnostic],
) -> ImportedExpression:
    warnings = list(notes)
    signals: list[gr.GretaSignal] = []
    seen: dict[str, Span] = {}
    for element in gr.elements(signals_parent, "signal") if signals_parent is not None else []:
        signal = gr.read_signal(signal_file, element, attribute_map, modality_attribute, errors)
        if signal is None:
            continue
        if signal.id in seen:
            errors.append(Diagnostic("E201", f"duplicate Greta signal id {signal.greta_id} "
                                     f"(first at line {seen[signal.id].line})", signal.span))
            continue
        seen[signal.id] = signal.span
        signals.append(signal)
    if not signals:
        where = signal_file.span(signals_parent) if signals_parent is not None else Span(
            signal_file.path)
        errors.append(Diagnostic("E209", f"emotion '{name}' has no signals", where))
    gw.warn_dropped(signals, signal_file, warnings)
    every_signal = signals
    signals, never = _without_impossible(signals, warnings)
    known = frozenset(s.id for s in signals)
    ids = gw.IdMaker()
    converted: list[gw.NativeConstraint] = []
    reader = gr.ConReader(con_file, errors, warnings)
    for position, con in enumerate(cons, start=1):
        expr = reader.read(con)
        span = con_file.span(con)
        label = con.get("label")
        constraint_id = ids.from_label(label, position, span, warnings)
        origin = f"{con_file.name}:{span.line}" + (f" label {label}" if label else "")
        if expr is not None:
            _add(converted, constraint_id, expr, known, signals, span, origin, warnings)
    if lexicon_constraints is not None:
        for expr, span, what in gw.lexicon_rules(signal_file, lexicon_constraints, warnings):
            origin = f"{signal_file.name}:{span.line} {what}"
            _add(converted, ids.fresh(f"lexicon_{what}"), expr, known, signals, span, origin,
                 warnings)
    for owner, left, right in gw.excludelist_pairs(every_signal, converted, warnings):
        if left in never or right in never:
            continue
        origin = f"{signal_file.name}:{owner.span.line} excludelist of signal {owner.greta_id}"
        converted.append(gw.NativeConstraint(ids.fresh(f"excludelist_{left.id}_{right.id}"),
                                     f"excludes({left.id}, {right.id})", origin))
    description = (
        f"Imported from Greta by mse import-greta: emotion '{name}'"
        + (f" (the paper's '{PAPER_NAMES[name]}')" if name in PAPER_NAMES else "")
        + f", from the {sources}. Signal sN is Greta's signal id N; constraint ids are "
        "Greta's labels. Mapping and approximations: docs/greta.md."
    )
    xml = gw.native_xml(name, description, signals, converted)
    return ImportedExpression(name, xml, tuple(sorted(warnings, key=Diagnostic.sort_key)),
                              len(signals), len(converted))


def _without_impossible(
    signals: list[gr.GretaSignal], warnings: list[Diagnostic]
) -> tuple[list[gr.GretaSignal], list[gr.GretaSignal]]:
    """Split off signals with max 0: they can never be displayed (an occurrence needs
    start < stop), which is exactly a signal absent from the set, so they are left out and
    constraints naming them are read as for an absent signal."""
    kept: list[gr.GretaSignal] = []
    never: list[gr.GretaSignal] = []
    for signal in signals:
        if signal.attributes.get("max_duration") == "0":
            never.append(signal)
            warnings.append(Diagnostic(
                "W502", f"signal {signal.greta_id} ({signal.lexeme}) has max 0 and can never "
                f"occur; left out ({signal.id} is read as an absent signal)", signal.span))
        else:
            kept.append(signal)
    return kept, never


def _add(
    converted: list[gw.NativeConstraint],
    constraint_id: str,
    expr: GExpr,
    known: frozenset[str],
    signals: list[gr.GretaSignal],
    span: Span,
    origin: str,
    warnings: list[Diagnostic],
) -> None:
    """Simplify what the native language cannot say, warn, and keep the constraint text."""
    simplified, rewrite = simplify(expr, known)
    for relation in rewrite.self_relations:
        holds = relation.kind in ("includes", "rightincludes")
        warnings.append(Diagnostic(
            "W502", f"constraint '{constraint_id}': {relation.kind}({relation.left}, "
            f"{relation.left}) relates a signal with itself; written as "
            f"{'' if holds else 'not '}exists({relation.left})", span))
    if not rewrite.missing:
        converted.append(gw.NativeConstraint(constraint_id, render(flatten(simplified)), origin))
        return
    missing = ", ".join(sorted(rewrite.missing))
    subject = f"constraint '{constraint_id}' names {missing}, absent from the behaviour set"
    if isinstance(simplified, GConst) and simplified != FALSE:
        warnings.append(Diagnostic("W502", f"{subject}: it can never be violated; left out",
                                   span))
        return
    if simplified == FALSE:  # false whenever instantiated: its other triggers must not occur
        present = sorted(triggers_of(expr) & known)
        if present:
            simplified = gw.conjunction([GNot(GExists(s)) for s in present])
        elif signals:  # always violated: keep it so (the set has no consistent timeline)
            simplified = gw.conjunction([GExists(signals[0].id), GNot(GExists(signals[0].id))])
    if has_constant(simplified):
        warnings.append(Diagnostic(
            "W502", f"{subject}; the rest cannot be stated without it; left out", span))
        return
    text = render(flatten(simplified))
    warnings.append(Diagnostic(
        "W502", f"{subject} (exists false, its relations unknown); written as {text}", span))
    converted.append(gw.NativeConstraint(constraint_id, text, origin))


def _expect_root(file: gr.GretaFile, tag: str, errors: list[Diagnostic]) -> None:
    if file.root.tag != tag:
        errors.append(Diagnostic("E102", f"expected a Greta <{tag}> file, found <{file.root.tag}>",
                                 file.span(file.root)))


def _first(parent: etree._Element, tag: str) -> etree._Element | None:
    found = gr.elements(parent, tag)
    return found[0] if found else None


def _report(expressions: list[ImportedExpression], loose: list[Diagnostic]) -> GretaImport:
    everything = [d for e in expressions for d in e.diagnostics] + loose
    return GretaImport(tuple(expressions), tuple(sorted(everything, key=Diagnostic.sort_key)))


__all__ = [
    "GretaImport",
    "ImportedExpression",
    "import_greta",
    "import_greta_legacy",
    "import_greta_legacy_report",
    "import_greta_report",
]
