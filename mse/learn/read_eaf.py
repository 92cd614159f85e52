"""ELAN annotation files (``.eaf``, EAF 2.7 to 3.0) as raw sequences.

Read with lxml (the same safe parser as behaviour sets: no entities, no DTD, no network),
so that every problem points at its line.  What is read: ``TIME_ORDER`` (time slots in
milliseconds), every ``TIER`` with its ``ALIGNABLE_ANNOTATION`` elements (start and stop
slots, ``ANNOTATION_VALUE``), and ``REF_ANNOTATION`` elements, which take the times of the
annotation they refer to.  A file written by ``mse ... --format eaf`` carries the
timeline's duration as the header property ``mse:duration`` (milliseconds); other files
last until their last annotation.  The tests read the same files with pympi-ling, an
independent reader, and compare.
"""

from __future__ import annotations

from pathlib import Path

from lxml import etree

from mse.diagnostics import Diagnostic, Span
from mse.learn.corpus import Annotation, RawSequence
from mse.limits import XML_SPACE, parse_integer
from mse.syntax.reader import parse_xml, read_bytes

#: Header property holding a timeline's duration in ms (written by mse.export.eaf).
DURATION_PROPERTY = "mse:duration"
SUPPORTED_VERSIONS = ("2.7", "2.8", "3.0")


def _line(element: etree._Element) -> int:
    line = getattr(element, "sourceline", None)
    return line if isinstance(line, int) else 0


def read_eaf(path: str | Path, data: bytes | None = None) -> tuple[RawSequence | None, list[Diagnostic]]:
    """One ELAN file as one sequence; None with E-diagnostics when it cannot be read."""
    name = str(path)
    if data is None:
        data, problems = read_bytes(path)
        if data is None:
            return None, problems
    root, _source, problems = parse_xml(data, name)
    if root is None:
        return None, problems
    reader = _EafReader(root, name)
    sequence = reader.read()
    return sequence, reader.found


class _EafReader:
    def __init__(self, root: etree._Element, path: str) -> None:
        self.root = root
        self.path = path
        self.found: list[Diagnostic] = []

    def span(self, element: etree._Element) -> Span:
        return Span(self.path, _line(element), 1)

    def error(self, message: str, element: etree._Element) -> None:
        self.found.append(Diagnostic("E120", message, self.span(element)))

    def note(self, message: str, element: etree._Element) -> None:
        self.found.append(Diagnostic("W503", message, self.span(element)))

    def read(self) -> RawSequence | None:
        root = self.root
        if root.tag != "ANNOTATION_DOCUMENT":
            self.error(f"not an ELAN file: the root element is <{root.tag}>, not <ANNOTATION_DOCUMENT>", root)
            return None
        version = root.get("VERSION") or root.get("FORMAT") or ""
        if version not in SUPPORTED_VERSIONS:
            self.note(f"EAF version {version or '(none)'} is not one of {', '.join(SUPPORTED_VERSIONS)}; "
                      "read as EAF 3.0", root)
        duration = self._header(root.find("HEADER"))
        slots = self._time_slots(root.find("TIME_ORDER"))
        if slots is None:
            return None
        annotations = self._tiers(slots)
        if any(d.is_error for d in self.found):
            return None
        if duration is not None:
            late = [a for a in annotations if a.stop > duration]
            if late:
                self.error(f"annotation ends at {late[0].stop} ms, after the {DURATION_PROPERTY} of {duration} ms",
                           root)
                return None
        return RawSequence(Path(self.path).stem, tuple(annotations), Span(self.path), duration)

    def _header(self, header: etree._Element | None) -> int | None:
        if header is None:
            self.error("<HEADER> is missing", self.root)
            return None
        units = header.get("TIME_UNITS", "milliseconds")
        if units != "milliseconds":
            self.error(f"TIME_UNITS {units!r} is not supported (only milliseconds)", header)
        for prop in header.iter("PROPERTY"):
            if prop.get("NAME") == DURATION_PROPERTY:
                value = (prop.text or "").strip()
                duration = _milliseconds(value)
                if duration is None or duration <= 0:
                    self.error(f"{DURATION_PROPERTY} must be a positive number of milliseconds, "
                               f"not {value[:40]!r}", prop)
                    return None
                return duration
        return None

    def _time_slots(self, order: etree._Element | None) -> dict[str, int | None] | None:
        if order is None:
            self.error("<TIME_ORDER> is missing", self.root)
            return None
        slots: dict[str, int | None] = {}
        for slot in order.iter("TIME_SLOT"):
            slot_id = slot.get("TIME_SLOT_ID")
            if not slot_id:
                self.error("<TIME_SLOT> without TIME_SLOT_ID", slot)
                continue
            if slot_id in slots:
                self.error(f"duplicate TIME_SLOT_ID {slot_id!r}", slot)
                continue
            value = slot.get("TIME_VALUE")
            if value is None:
                slots[slot_id] = None  # unaligned
                continue
            milliseconds = _milliseconds(value)
            if milliseconds is None:
                self.error(f"TIME_VALUE of {slot_id!r} must be a whole number of milliseconds "
                           f"(ASCII digits, at most 15), not {value[:40]!r}", slot)
                continue
            slots[slot_id] = milliseconds
        return slots

    def _tiers(self, slots: dict[str, int | None]) -> list[Annotation]:
        aligned: dict[str, tuple[int, int] | None] = {}  # annotation id -> times
        references: list[tuple[str, str, str, etree._Element]] = []  # (tier, label, ref id, element)
        found: list[Annotation] = []
        for tier in self.root.iter("TIER"):
            tier_id = tier.get("TIER_ID")
            if not tier_id:
                self.error("<TIER> without TIER_ID", tier)
                continue
            for alignable in tier.iter("ALIGNABLE_ANNOTATION"):
                times = self._alignable(alignable, slots)
                annotation_id = alignable.get("ANNOTATION_ID") or ""
                aligned[annotation_id] = times
                if times is None:
                    continue
                label = _value(alignable)
                found.append(Annotation(tier_id, label, times[0], times[1], self.span(alignable)))
            for ref in tier.iter("REF_ANNOTATION"):
                references.append((tier_id, _value(ref), ref.get("ANNOTATION_REF") or "", ref))
        for tier_id, label, target, element in references:
            times = aligned.get(target)
            if target not in aligned:
                self.error(f"REF_ANNOTATION refers to unknown annotation {target!r}", element)
            elif times is not None:
                found.append(Annotation(tier_id, label, times[0], times[1], self.span(element)))
        return found

    def _alignable(self, element: etree._Element, slots: dict[str, int | None]) -> tuple[int, int] | None:
        first, second = element.get("TIME_SLOT_REF1"), element.get("TIME_SLOT_REF2")
        for ref in (first, second):
            if ref is None or ref not in slots:
                self.error(f"ALIGNABLE_ANNOTATION refers to unknown time slot {ref!r}", element)
                return None
        assert first is not None and second is not None
        start, stop = slots[first], slots[second]
        if start is None or stop is None:
            self.note("annotation with an unaligned time slot (no TIME_VALUE); left out", element)
            return None
        if stop < start:
            self.error(f"annotation ends ({stop} ms) before it starts ({start} ms)", element)
            return None
        if stop == start:
            self.note(f"annotation of length 0 at {start} ms; left out", element)
            return None
        return start, stop


def _value(element: etree._Element) -> str:
    value = element.find("ANNOTATION_VALUE")
    return (value.text or "").strip() if value is not None else ""


def _milliseconds(text: str) -> int | None:
    """A whole number of milliseconds in ASCII digits (``str.isdigit`` also takes "²" and
    Arabic-Indic or full-width digits), at most 15 digits (31,000 years), else None."""
    return parse_integer(text, max_digits=15) if not text.strip(XML_SPACE).startswith(("+", "-")) else None
