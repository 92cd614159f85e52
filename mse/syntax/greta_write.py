"""Writing imported Greta emotions: constraint ids, lexicon rules, excludelists, the XML.

Helpers of :mod:`mse.syntax.greta` kept apart so that each module stays small.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from lxml import etree

from mse.diagnostics import Diagnostic, Span
from mse.syntax import greta_read as gr
from mse.syntax.greta_expr import GAnd, GExists, GExpr, GImplies, GNot

_ID = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


@dataclass(frozen=True, slots=True)
class NativeConstraint:
    id: str
    text: str
    origin: str  # shown as an XML comment: where in Greta it came from


def conjunction(parts: list[GExpr]) -> GExpr:
    return parts[0] if len(parts) == 1 else GAnd(tuple(parts))


def lexicon_rules(
    file: gr.GretaFile, holder: etree._Element, warnings: list[Diagnostic]
) -> list[tuple[GExpr, Span, str]]:
    """``<core><item id=N/>`` -> exists(sN); ``<implication>`` -> if ... implies then ..."""
    found: list[tuple[GExpr, Span, str]] = []
    for core in gr.elements(holder, "core"):
        for item in gr.elements(core, "item"):
            identifier = gr.native_id(item.get("id") or "")
            if identifier is not None:
                found.append((GExists(identifier), file.span(item), f"core_{identifier}"))
    count = 0
    for rules in gr.elements(holder, "rules"):
        for rule in gr.elements(rules, "implication"):
            count += 1
            parts: dict[str, list[GExpr]] = {"if": [], "then": []}
            for item in rule:
                if not isinstance(item.tag, str):
                    continue
                identifier = gr.native_id(item.get("id") or "")
                kinds = {"ifpresent": ("if", False), "thenpresent": ("then", False),
                         "thennotpresent": ("then", True), "ifnotpresent": ("if", True)}
                if identifier is None or item.tag not in kinds:
                    warnings.append(Diagnostic("W502", f"<{item.tag}> in a rule not understood;"
                                               " ignored", file.span(item)))
                    continue
                side, negated = kinds[str(item.tag)]
                atom: GExpr = GExists(identifier)
                parts[side].append(GNot(atom) if negated else atom)
            if parts["if"] and parts["then"]:
                found.append((GImplies(conjunction(parts["if"]), conjunction(parts["then"])),
                              file.span(rule), f"rule_{count}"))
    return found


def excludelist_pairs(
    signals: list[gr.GretaSignal], converted: list[NativeConstraint], warnings: list[Diagnostic]
) -> list[tuple[gr.GretaSignal, gr.GretaSignal, gr.GretaSignal]]:
    """Resolve excludelist names (bare, without class prefix) to signal pairs, once each.

    Returns (signal whose excludelist says it, first, second) in behaviour-set order; a pair
    already stated by an ``excludes`` of the constraint file is not repeated."""
    by_name: dict[str, list[gr.GretaSignal]] = {}
    for signal in signals:
        by_name.setdefault(signal.bare_name, []).append(signal)
        if signal.lexeme != signal.bare_name:
            by_name.setdefault(signal.lexeme, []).append(signal)
    order = {s.id: index for index, s in enumerate(signals)}
    stated = {frozenset(m.groups()) for c in converted
              if (m := re.fullmatch(r"excludes\((\w+), (\w+)\)", c.text))}
    pairs: list[tuple[gr.GretaSignal, gr.GretaSignal, gr.GretaSignal]] = []
    done: set[frozenset[str]] = set()
    for signal in signals:
        for entry in signal.excludelist:
            targets = by_name.get(entry, [])
            if not targets:
                warnings.append(Diagnostic(
                    "W502", f"excludelist of signal {signal.greta_id} names '{entry}', which is "
                    "no signal of this set; ignored", signal.excludelist_span))
            for target in targets:
                key = frozenset({signal.id, target.id})
                if target.id == signal.id or key in done or key in stated:
                    continue
                done.add(key)
                first, second = sorted((signal, target), key=lambda s: order[s.id])
                pairs.append((signal, first, second))
    return pairs


def warn_dropped(signals: list[gr.GretaSignal], file: gr.GretaFile,
                  warnings: list[Diagnostic]) -> None:
    """Greta attributes with no counterpart (legacy ``occurence``, ``meaning``...): one note."""
    dropped: dict[str, set[str]] = {}
    first: dict[str, Span] = {}
    for signal in signals:
        for key, value in signal.dropped.items():
            dropped.setdefault(key, set()).add(value)
            first.setdefault(key, signal.span)
    for key, values in sorted(dropped.items()):
        shown = ", ".join(sorted(values))
        warnings.append(Diagnostic(
            "W502", f"Greta signal {'element' if key.startswith('<') else 'attribute'} "
            f"'{key.strip('<>')}' (values {shown}) has no counterpart in the MSE language; "
            "dropped", first[key]))


class IdMaker:
    def __init__(self) -> None:
        self.used: set[str] = set()

    def fresh(self, base: str) -> str:
        candidate, suffix = base, 2
        while candidate in self.used:
            candidate, suffix = f"{base}_{suffix}", suffix + 1
        self.used.add(candidate)
        return candidate

    def from_label(self, label: str | None, position: int, span: Span,
                   warnings: list[Diagnostic]) -> str:
        if not label:
            return self.fresh(f"con_{position}")
        chosen = self.fresh(identifier(label))
        if chosen != label:
            warnings.append(Diagnostic("W501", f"Greta label '{label}' written as constraint id "
                                       f"'{chosen}'", span))
        return chosen


def identifier(text: str | None) -> str:
    cleaned = re.sub(r"[^A-Za-z0-9_]", "_", (text or "").strip())
    if not cleaned:
        return "unnamed"
    return cleaned if _ID.fullmatch(cleaned) else f"_{cleaned}"


def unique_name(name: str, taken: set[str]) -> str:
    candidate, suffix = name, 2
    while candidate in taken:
        candidate, suffix = f"{name}_{suffix}", suffix + 1
    taken.add(candidate)
    return candidate


def native_xml(name: str, description: str, signals: list[gr.GretaSignal],
                constraints: list[NativeConstraint]) -> str:
    root = etree.Element("expression", name=name)
    etree.SubElement(root, "description").text = description
    holder = etree.SubElement(root, "signals")
    for signal in signals:
        element = etree.SubElement(holder, "signal", id=signal.id, modality=signal.modality,
                                   lexeme=signal.lexeme)
        for key in ("min_duration", "max_duration", "probability_start", "probability_end",
                    "repetitivity"):
            if key in signal.attributes:
                element.set(key, signal.attributes[key])
    if constraints:
        holder = etree.SubElement(root, "constraints")
        for constraint in constraints:
            holder.append(etree.Comment(f" {_comment_safe(constraint.origin)} "))
            etree.SubElement(holder, "constraint", id=constraint.id).text = constraint.text
    etree.indent(root, space="  ")
    body = etree.tostring(root, encoding="unicode")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + body + "\n"


def _comment_safe(text: str) -> str:
    """XML comments may not contain ``--`` (labels are free text)."""
    while "--" in text:
        text = text.replace("--", "- -")
    return text
