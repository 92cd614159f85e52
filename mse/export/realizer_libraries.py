"""Readers of Greta's realizer libraries: face library, head and torso gestures, gestuary.

Greta's behaviour realizer fills every signal from four XML files in
``bin/BehaviorRealizer/BehaviorLexicon`` (``../shared/greta`` holds copies):

- ``facelibrary.xml``: ``<expression class="faceexp" instance="joy">`` with FACS ``<action
  name="AU12" intensity="0.8" side="LEFT"/>``; Greta looks faces up as ``faceexp=<name>``;
- ``HeadGestures.xml``: ``<head id="Nod_Middle" lexeme="NOD">`` with ``<KeyPoint>`` rotations and
  ``<headDirectionShift id="Forward">`` held orientations; found by id, then by ``lexeme``;
- ``TorsoGestures.xml``: ``<torso id="BodyLean">`` and ``<torsoDirectionShift id="forward_lean">``,
  found by id (a torso Greta cannot find makes its realizer throw);
- a gestuary (``gestuary.xml``, or the one ``gestuary_*.xml``): ``<gesture category="rest"
  id="akimbo">``, found as ``<category>=<id>``.

Every lookup is case-insensitive, as Greta's.  The files are read in place (they are GPL/LGPL
data: never copied into this repository), as plain data: no DTD, no entities, no network.
Unreadable files raise :class:`MseError` with E100, malformed XML E101, files over
:data:`MAX_LIBRARY_BYTES` E104.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal, Protocol

from mse.diagnostics import Diagnostic, MseError, Span

if TYPE_CHECKING:
    from lxml import etree

MAX_LIBRARY_BYTES = 20 * 1024 * 1024
FACE_LIBRARY_FILE = "facelibrary.xml"
HEAD_GESTURES_FILE = "HeadGestures.xml"
TORSO_GESTURES_FILE = "TorsoGestures.xml"

Axis = Literal["SagittalTilt", "VerticalTorsion", "LateralRoll"]
AXES: tuple[Axis, ...] = ("SagittalTilt", "VerticalTorsion", "LateralRoll")


class LexemeName(Protocol):
    """What a lookup needs of a lexeme (``mse.export.lexemes.Lexeme`` is one)."""

    @property
    def klass(self) -> str: ...

    @property
    def name(self) -> str: ...


# -- records ------------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class ActionUnit:
    """One FACS action unit of a face-library expression (intensity in [0, 1])."""

    number: int
    intensity: float = 1.0
    side: str = "BOTH"


@dataclass(frozen=True)
class FaceLibrary:
    """``(class, instance)`` (lower case) -> action units, from Greta's ``facelibrary.xml``.

    ``names`` keeps each instance as the library spells it (``Smile_Big_Open``)."""

    entries: Mapping[tuple[str, str], tuple[ActionUnit, ...]]
    names: Mapping[tuple[str, str], str] = field(default_factory=dict)

    def resolve(self, lexeme: LexemeName) -> tuple[ActionUnit, ...] | None:
        """The action units of ``lexeme``, or None when the library does not name it."""
        name = lexeme.name.lower()
        if lexeme.klass:
            return self.entries.get((lexeme.klass.lower(), name))
        for klass in ("faceexp", "gaze"):
            found = self.entries.get((klass, name))
            if found is not None:
                return found
        return None

    def instances(self, klass: str) -> list[str]:
        """The instance names of one class (``faceexp``, ``gaze``) as the library spells them."""
        wanted = klass.lower()
        return sorted(self.names.get(key, key[1]) for key in self.entries if key[0] == wanted)


@dataclass(frozen=True, slots=True)
class Rotation:
    """One rotation of a key point: ``SagittalTilt`` Forward/Backward (pitch), ``VerticalTorsion``
    Leftward/Rightward (yaw), ``LateralRoll`` Leftward/Rightward (roll).

    Greta's values are symbolic, in [0, 1] of the joint's range (HeadIntervals.xml gives the
    degrees): a head gesture plays ``minimum + SPC * (maximum - minimum)``, a direction shift
    ``maximum``; ``amount`` is the torso direction shifts' own scale."""

    axis: Axis
    direction: str
    minimum: float
    maximum: float
    amount: float | None = None


@dataclass(frozen=True, slots=True)
class KeyPoint:
    """``<KeyPoint type="strokeEnd">`` (type ``""`` when the file gives none)."""

    type: str
    rotations: tuple[Rotation, ...]


@dataclass(frozen=True, slots=True)
class Movement:
    """A head or torso entry: ``<head>``/``<torso>`` (a gesture) or ``*DirectionShift`` (a held
    orientation).  Torso key points written as vertebra quaternions keep only their type."""

    id: str
    lexeme: str
    kind: str
    keypoints: tuple[KeyPoint, ...]
    repetition: int = 1
    line: int = 0


@dataclass(frozen=True)
class MovementLibrary:
    """Greta's ``HeadGestures.xml`` or ``TorsoGestures.xml``."""

    movements: tuple[Movement, ...]
    path: str = ""

    def by_id(self, name: str) -> Movement | None:
        wanted = name.strip().lower()
        return next((m for m in self.movements if m.id.lower() == wanted), None)

    def by_lexeme(self, name: str) -> Movement | None:
        wanted = name.strip().lower()
        return next((m for m in self.movements if m.lexeme and m.lexeme.lower() == wanted), None)

    def ids(self) -> list[str]:
        return sorted({m.id for m in self.movements if m.id})

    def lexemes(self) -> list[str]:
        return sorted({m.lexeme for m in self.movements if m.lexeme})


@dataclass(frozen=True, slots=True)
class Gesture:
    """``<gesture category="rest" id="akimbo">``: ``phases`` and the ``hands`` they use."""

    category: str
    id: str
    phases: int = 0
    hands: tuple[str, ...] = ()
    line: int = 0

    @property
    def reference(self) -> str:
        return f"{self.category}={self.id}"


@dataclass(frozen=True)
class Gestuary:
    gestures: tuple[Gesture, ...]
    path: str = ""

    def find(self, reference: str) -> Gesture | None:
        """The gesture Greta finds for ``category=id`` (case-insensitive), or None."""
        wanted = reference.strip().lower()
        return next((g for g in self.gestures if g.reference.lower() == wanted), None)

    def with_id(self, name: str) -> list[Gesture]:
        wanted = name.strip().lower()
        return [g for g in self.gestures if g.id.lower() == wanted]

    def references(self) -> list[str]:
        return sorted({g.reference for g in self.gestures})


@dataclass(frozen=True)
class GretaLibraries:
    """The four libraries Greta's realizer fills signals from, read from one folder."""

    directory: Path
    face: FaceLibrary
    head: MovementLibrary
    torso: MovementLibrary
    gestuary: Gestuary


# -- reading ------------------------------------------------------------------------------------
def _error(code: str, message: str, where: str, line: int = 0, col: int = 0) -> MseError:
    return MseError([Diagnostic(code, message, Span(where, line, col))])


def read_library_xml(path: Path, what: str) -> etree._Element:
    """The root element of a realizer library, read as plain data (E100/E101/E104)."""
    from mse.input_files import read_input
    from mse.syntax.safexml import parse_xml

    where = str(path)
    # Regular files only, size-capped; entities refused on the parsed DOCTYPE (mse.fileio,
    # mse.syntax.safexml: the one reader of files and of XML).
    root, _, problems = parse_xml(read_input(path, limit=MAX_LIBRARY_BYTES, what=what), where)
    if root is None:
        raise MseError(problems)
    return root


def _float(text: str | None, default: float) -> float:
    try:
        return float(text) if text is not None else default
    except ValueError:
        return default


def _line(element: etree._Element) -> int:
    line = getattr(element, "sourceline", None)
    return line if isinstance(line, int) else 0


def _elements(parent: etree._Element, tag: str) -> list[etree._Element]:
    return [child for child in parent.iter(tag) if isinstance(child.tag, str)]


def load_face_library(path: Path) -> FaceLibrary:
    """Read a Greta face library; unreadable -> E100, malformed XML -> E101 (MseError)."""
    root = read_library_xml(path, "face library")
    entries: dict[tuple[str, str], tuple[ActionUnit, ...]] = {}
    names: dict[tuple[str, str], str] = {}
    for expression in _elements(root, "expression"):
        klass = (expression.get("class") or "faceexp").strip().lower()
        instance = (expression.get("instance") or "").strip()
        if not instance:
            continue
        units: list[ActionUnit] = []
        for action in _elements(expression, "action"):
            unit = _action_unit(action.get("name") or "", action.get("intensity"), action.get("side"))
            if unit is not None:
                units.append(unit)
        key = (klass, instance.lower())
        entries[key] = tuple(units)
        names[key] = instance
    return FaceLibrary(entries, names)


def _action_unit(name: str, intensity: str | None, side: str | None) -> ActionUnit | None:
    match = re.fullmatch(r"\s*AU\s*(\d+)\s*", name, flags=re.IGNORECASE)
    if match is None:
        return None
    value = _float(intensity, 1.0)
    side_name = (side or "BOTH").strip().upper()
    if side_name not in ("LEFT", "RIGHT", "BOTH"):
        side_name = "BOTH"
    return ActionUnit(int(match.group(1)), max(0.0, min(1.0, value)), side_name)


def _rotations(parent: etree._Element) -> tuple[Rotation, ...]:
    found = []
    for child in parent:
        if isinstance(child.tag, str) and child.tag in AXES:
            amount = child.get("amount")
            found.append(
                Rotation(
                    child.tag,
                    (child.get("direction") or "").strip(),
                    _float(child.get("min"), 0.0),
                    _float(child.get("max"), 0.0),
                    None if amount is None else _float(amount, 0.0),
                )
            )
    return tuple(found)


def _movement(entry: etree._Element) -> Movement:
    keypoints = [
        KeyPoint((point.get("type") or "").strip(), _rotations(point))
        for point in entry
        if isinstance(point.tag, str) and point.tag.lower() == "keypoint"
    ]
    direct = _rotations(entry)
    if direct:
        keypoints.insert(0, KeyPoint("", direct))
    repetition = entry.get("repetition")
    return Movement(
        id=(entry.get("id") or "").strip(),
        lexeme=(entry.get("lexeme") or "").strip(),
        kind=str(entry.tag),
        keypoints=tuple(keypoints),
        repetition=int(_float(repetition, 1.0)) if repetition is not None else 1,
        line=_line(entry),
    )


def load_movement_library(path: Path, body_part: Literal["head", "torso"]) -> MovementLibrary:
    """Read ``HeadGestures.xml`` (``body_part="head"``) or ``TorsoGestures.xml`` (``"torso"``)."""
    root = read_library_xml(path, f"{body_part} gesture library")
    tags = (body_part, f"{body_part}DirectionShift")
    movements = tuple(_movement(entry) for entry in root.iter(*tags) if isinstance(entry.tag, str))
    return MovementLibrary(movements, str(path))


def load_head_gestures(path: Path) -> MovementLibrary:
    return load_movement_library(path, "head")


def load_torso_gestures(path: Path) -> MovementLibrary:
    return load_movement_library(path, "torso")


def load_gestuary(path: Path) -> Gestuary:
    root = read_library_xml(path, "gestuary")
    gestures = []
    for entry in _elements(root, "gesture"):
        phases = [p for p in entry if isinstance(p.tag, str) and p.tag == "phase"]
        hands = sorted({(h.get("side") or "").upper() for p in phases for h in _elements(p, "hand")} - {""})
        gestures.append(
            Gesture(
                category=(entry.get("category") or "").strip(),
                id=(entry.get("id") or "").strip(),
                phases=len(phases),
                hands=tuple(hands),
                line=_line(entry),
            )
        )
    return Gestuary(tuple(gestures), str(path))


def gestuary_path(directory: Path) -> Path:
    """``gestuary.xml`` when the folder has it, else its only ``gestuary_*.xml`` (E100 otherwise).

    Greta's own ``bin/BehaviorRealizer/BehaviorLexicon`` has both: its default character plays
    ``gestuary.xml``; ``../shared/greta`` has only ``gestuary_poppy.xml``."""
    plain = directory / "gestuary.xml"
    if plain.is_file():
        return plain
    candidates = sorted(p for p in directory.glob("gestuary_*.xml") if p.is_file())
    if len(candidates) == 1:
        return candidates[0]
    found = ", ".join(p.name for p in candidates) or "none"
    message = f"no single gestuary in the library folder (gestuary.xml or one gestuary_*.xml; found: {found})"
    raise _error("E100", message, str(directory))


def load_greta_libraries(directory: Path) -> GretaLibraries:
    """Greta's four realizer libraries from one folder (see the module docstring)."""
    if not directory.is_dir():
        raise _error("E100", "realizer library folder not found", str(directory))
    return GretaLibraries(
        directory=directory,
        face=load_face_library(directory / FACE_LIBRARY_FILE),
        head=load_head_gestures(directory / HEAD_GESTURES_FILE),
        torso=load_torso_gestures(directory / TORSO_GESTURES_FILE),
        gestuary=load_gestuary(gestuary_path(directory)),
    )


def axis_rotations(movement: Movement) -> dict[Axis, tuple[Rotation, ...]]:
    """Every rotation of ``movement`` grouped by axis (key-point order kept)."""
    grouped: dict[Axis, list[Rotation]] = {axis: [] for axis in AXES}
    for point in movement.keypoints:
        for rotation in point.rotations:
            grouped[rotation.axis].append(rotation)
    return {axis: tuple(rotations) for axis, rotations in grouped.items()}
