"""The learned behaviour set as XML text that the reader accepts (round trip tested).

Every signal and rule carries its evidence in an XML comment right above it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from mse.export.xmltext import Comment, Element, document, element
from mse.ir import model as ir
from mse.ir.printer import expr_text


def _number(value: float) -> str:
    return f"{value:.3f}".rstrip("0").rstrip(".") or "0"


def signal_element(signal: ir.Signal) -> Element:
    attributes: dict[str, str | float | int | None] = {
        "id": signal.id,
        "modality": signal.modality,
        "lexeme": signal.lexeme,
        "min_duration": _number(signal.min_duration),
        "max_duration": None if signal.max_duration is None else _number(signal.max_duration),
        "probability_start": _number(signal.probability_start),
        "probability_end": _number(signal.probability_end),
        "repetitivity": str(signal.repetitivity),
        "max_occurrences": None if signal.max_occurrences is None else str(signal.max_occurrences),
    }
    if signal.motion is not None:
        return element("signal", attributes, element("motion", {"action": signal.motion.action}))
    return element("signal", attributes)


def behaviour_set_xml(
    model: ir.Model,
    *,
    description: str,
    signal_notes: Mapping[str, str],
    constraint_notes: Mapping[str, str],
    modality_notes: Mapping[str, str],
    header: Sequence[str] = (),
) -> str:
    children: list[Element | Comment | str] = [element("description", {}, description)]
    for modality in model.modalities:
        note = modality_notes.get(modality.name)
        if note:
            children.append(Comment(note))
        children.append(element("modality", {"name": modality.name, "exclusive": "true" if modality.exclusive
                                             else "false"}))
    signals: list[Element | Comment | str] = []
    for signal in model.signals:
        note = signal_notes.get(signal.id)
        if note:
            signals.append(Comment(note))
        signals.append(signal_element(signal))
    children.append(element("signals", {}, *signals))
    if model.constraints:
        constraints: list[Element | Comment | str] = []
        for constraint in model.constraints:
            note = constraint_notes.get(constraint.id)
            if note:
                constraints.append(Comment(note))
            constraints.append(element("constraint", {"id": constraint.id}, expr_text(constraint.expr)))
        children.append(element("constraints", {}, *constraints))
    root = element("expression", {"name": model.name}, *children)
    return document(root, leading=[Comment(line) for line in header])
