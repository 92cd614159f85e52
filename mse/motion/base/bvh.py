"""BVH reading, writing and forward kinematics, in-house with numpy.

Stable API (other modules and the HSMM method build on it):

``Skeleton`` (frozen)
    ``names`` (joint names, parents before children), ``parents`` (index, -1 for the root),
    ``offsets`` (J, 3) from the ``OFFSET`` lines, ``channels`` (per joint, the channel names in
    file order, e.g. ``("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation",
    "Yrotation")``), ``end_sites`` (per joint, the ``End Site`` offset or None).
    Derived: ``channel_count``, ``channel_starts`` (first column of each joint),
    ``index(name)``, ``rotation_order(j)`` (e.g. ``"ZXY"`` or ``""``),
    ``rotation_columns(j)`` / ``position_columns(j)`` (column indices into the values),
    ``children(j)``.
``Motion`` (frozen)
    ``skeleton``, ``frame_time`` (seconds), ``values`` (frames x channels, degrees and file
    units). ``frame_count``, ``duration`` (frames x frame_time), ``translations()`` (F, J, 3),
    ``local_rotations()`` (F, J, 3, 3), ``positions()`` (F, J, 3 world positions via forward
    kinematics), ``with_values(values)``, ``slice(start, stop)``.
``read_bvh(path)`` / ``parse_bvh(text, path)`` -> Motion; bad input raises MseError (E100)
    with ``path:line``.
``write_bvh(path, motion)`` (atomic) / ``format_bvh(motion)`` -> str.

Channel semantics: position channels of any joint *replace* its OFFSET (Bandai puts six
channels on every joint; CMU and MoDa only on the root); rotation channels compose in file
order (``Zrotation Xrotation Yrotation`` -> ``Rz @ Rx @ Ry``), so Bandai (ZXY), CMU (ZYX and
ZXY mixed per joint) and MoDa (XYZ) are all read as written. Values are written with
``repr`` precision, so read -> write -> read is exact to far better than 1e-6.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from mse.diagnostics import Diagnostic, MseError, Span
from mse.fileio import write_atomic
from mse.input_files import read_input
from mse.limits import (
    MAX_BVH_BYTES,
    MAX_CHANNEL_VALUE,
    MAX_CHANNELS,
    MAX_FRAME_TIME,
    MAX_FRAMES,
    MIN_FRAME_TIME,
)
from mse.motion.base.kinematics import FloatArray, euler_to_matrix, forward_kinematics

#: Joints of one skeleton and their nesting (writing recurses once per level).
MAX_JOINTS = 1000
MAX_JOINT_DEPTH = 200

POSITION_CHANNELS = ("Xposition", "Yposition", "Zposition")
ROTATION_CHANNELS = ("Xrotation", "Yrotation", "Zrotation")
_VALID_CHANNELS = frozenset(POSITION_CHANNELS + ROTATION_CHANNELS)


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A BVH hierarchy: joints in file order (parents precede children)."""

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: FloatArray
    channels: tuple[tuple[str, ...], ...]
    end_sites: tuple[tuple[float, float, float] | None, ...]

    @property
    def joint_count(self) -> int:
        return len(self.names)

    @cached_property
    def channel_starts(self) -> tuple[int, ...]:
        starts, total = [], 0
        for joint_channels in self.channels:
            starts.append(total)
            total += len(joint_channels)
        return tuple(starts)

    @cached_property
    def channel_count(self) -> int:
        return sum(len(c) for c in self.channels)

    def index(self, name: str) -> int:
        return self.names.index(name)

    def children(self, joint: int) -> tuple[int, ...]:
        return tuple(j for j, p in enumerate(self.parents) if p == joint)

    def rotation_order(self, joint: int) -> str:
        return "".join(c[0] for c in self.channels[joint] if c in ROTATION_CHANNELS)

    def rotation_columns(self, joint: int) -> tuple[int, ...]:
        start = self.channel_starts[joint]
        names = self.channels[joint]
        return tuple(start + i for i, c in enumerate(names) if c in ROTATION_CHANNELS)

    def position_columns(self, joint: int) -> tuple[int, ...]:
        """Columns of X, Y, Z position (in that order), or () when the joint has none."""
        start = self.channel_starts[joint]
        names = self.channels[joint]
        if not all(axis in names for axis in POSITION_CHANNELS):
            return ()
        return tuple(start + names.index(axis) for axis in POSITION_CHANNELS)

    def same_layout(self, other: Skeleton) -> bool:
        """Same joints, parents and channels (offsets may differ: another performer)."""
        return self.names == other.names and self.parents == other.parents and self.channels == other.channels


@dataclass(frozen=True, eq=False)
class Motion:
    """A clip: a skeleton, a frame time (s) and the channel values (frames x channels)."""

    skeleton: Skeleton
    frame_time: float
    values: FloatArray

    @property
    def frame_count(self) -> int:
        return int(self.values.shape[0])

    @property
    def duration(self) -> float:
        return self.frame_count * self.frame_time

    def with_values(self, values: FloatArray) -> Motion:
        return Motion(self.skeleton, self.frame_time, np.asarray(values, dtype=np.float64))

    def slice(self, start: int, stop: int) -> Motion:
        return self.with_values(self.values[start:stop].copy())

    def translations(self) -> FloatArray:
        """(F, J, 3): position channels where a joint has them, else its OFFSET."""
        skeleton = self.skeleton
        out = np.broadcast_to(skeleton.offsets, (self.frame_count, skeleton.joint_count, 3)).copy()
        for joint in range(skeleton.joint_count):
            columns = skeleton.position_columns(joint)
            if columns:
                out[:, joint] = self.values[:, list(columns)]
        return out

    def local_rotations(self) -> FloatArray:
        """(F, J, 3, 3) local rotation matrices (identity for joints without rotations)."""
        skeleton = self.skeleton
        out = np.broadcast_to(np.eye(3), (self.frame_count, skeleton.joint_count, 3, 3)).copy()
        for joint in range(skeleton.joint_count):
            order = skeleton.rotation_order(joint)
            if len(order) == 3:
                out[:, joint] = euler_to_matrix(self.values[:, list(skeleton.rotation_columns(joint))], order)
        return out

    def positions(self) -> FloatArray:
        """(F, J, 3) world positions of every joint by forward kinematics."""
        positions, _ = forward_kinematics(self.skeleton.parents, self.translations(), self.local_rotations())
        return positions


# -- reading ------------------------------------------------------------------------------
class _Lines:
    """Tokenised lines with 1-based numbers, for error messages that point at the file."""

    def __init__(self, text: str, path: str) -> None:
        self.path = path
        self.raw = text.splitlines()
        self.position = 0

    def error(self, message: str, line: int | None = None) -> MseError:
        if line is None:
            line = min(self.position, len(self.raw))
        return MseError([Diagnostic("E100", f"invalid BVH: {message}", Span(self.path, line, 1))])

    def next(self) -> tuple[int, list[str]]:
        while self.position < len(self.raw):
            tokens = self.raw[self.position].split()
            self.position += 1
            if tokens:
                return self.position, tokens
        raise self.error("unexpected end of file")


def _floats(lines: _Lines, tokens: list[str], count: int, line: int) -> tuple[float, ...]:
    if len(tokens) != count:
        raise lines.error(f"expected {count} numbers, found {len(tokens)}", line)
    try:
        values = tuple(float(t) for t in tokens)
    except ValueError:
        raise lines.error(f"invalid number in {' '.join(tokens)!r}", line) from None
    if not all(np.isfinite(values)):
        raise lines.error("non-finite number", line)
    return values


def _parse_hierarchy(lines: _Lines) -> Skeleton:
    number, tokens = lines.next()
    if tokens != ["HIERARCHY"]:
        raise lines.error("the file must start with HIERARCHY", number)
    names: list[str] = []
    parents: list[int] = []
    offsets: list[tuple[float, ...]] = []
    channels: list[tuple[str, ...]] = []
    end_sites: list[tuple[float, float, float] | None] = []
    stack: list[int] = []  # joint index per open brace; -2 marks an End Site block
    number, tokens = lines.next()
    if len(tokens) != 2 or tokens[0] != "ROOT":
        raise lines.error("expected 'ROOT name'", number)
    pending: str | None = tokens[1]
    while True:
        if pending is not None:  # a joint header was just read: '{', OFFSET, CHANNELS
            number, tokens = lines.next()
            if tokens != ["{"]:
                raise lines.error("expected '{'", number)
            number, tokens = lines.next()
            if tokens[0] != "OFFSET":
                raise lines.error("expected OFFSET", number)
            offset = _floats(lines, tokens[1:], 3, number)
            number, tokens = lines.next()
            if tokens[0] != "CHANNELS" or len(tokens) < 2 or not _is_count(tokens[1]):
                raise lines.error("expected 'CHANNELS n ...'", number)
            joint_channels = tuple(tokens[2:])
            if int(tokens[1]) != len(joint_channels):
                raise lines.error(f"CHANNELS announces {tokens[1]} names", number)
            unknown = [c for c in joint_channels if c not in _VALID_CHANNELS]
            rotations = [c for c in joint_channels if c in ROTATION_CHANNELS]
            if unknown or len(set(joint_channels)) != len(joint_channels):
                raise lines.error(f"invalid channel list {' '.join(joint_channels)}", number)
            if len(rotations) not in (0, 3):
                raise lines.error("a joint needs 0 or 3 rotation channels", number)
            if len(names) >= MAX_JOINTS or len(stack) >= MAX_JOINT_DEPTH:
                raise lines.error(f"more than {MAX_JOINTS} joints or {MAX_JOINT_DEPTH} levels of nesting", number)
            names.append(pending)
            parents.append(stack[-1] if stack else -1)
            offsets.append(offset)
            channels.append(joint_channels)
            end_sites.append(None)
            stack.append(len(names) - 1)
            pending = None
        number, tokens = lines.next()
        head = tokens[0]
        if head == "JOINT" and len(tokens) == 2:
            if stack and stack[-1] == -2:
                raise lines.error("JOINT inside an End Site", number)
            pending = tokens[1]
        elif tokens == ["End", "Site"]:
            number_brace, brace = lines.next()
            number_offset, offset_tokens = lines.next()
            if brace != ["{"] or offset_tokens[0] != "OFFSET" or not stack:
                raise lines.error("malformed End Site", number_brace)
            end = _floats(lines, offset_tokens[1:], 3, number_offset)
            end_sites[stack[-1]] = (end[0], end[1], end[2])
            stack.append(-2)
        elif tokens == ["}"]:
            if not stack:
                raise lines.error("unbalanced '}'", number)
            stack.pop()
            if not stack:
                break
        else:
            raise lines.error(f"unexpected {' '.join(tokens)!r} in the hierarchy", number)
    if len(set(names)) != len(names):
        raise lines.error("duplicate joint names")
    return Skeleton(
        names=tuple(names),
        parents=tuple(parents),
        offsets=np.array(offsets, dtype=np.float64),
        channels=tuple(channels),
        end_sites=tuple(end_sites),
    )


def parse_bvh(text: str, path: str = "<bvh>") -> Motion:
    """Parse BVH text; raises MseError (E100) pointing at the offending line."""
    lines = _Lines(text, path)
    if not text.strip():
        raise lines.error("empty file", 0)
    skeleton = _parse_hierarchy(lines)
    number, tokens = lines.next()
    if tokens != ["MOTION"]:
        raise lines.error("expected MOTION", number)
    number, tokens = lines.next()
    if len(tokens) != 2 or tokens[0] != "Frames:" or not _is_count(tokens[1]):
        raise lines.error("expected 'Frames: n'", number)
    frame_count = int(tokens[1])
    if not 1 <= frame_count <= MAX_FRAMES:
        raise lines.error(f"'Frames: {frame_count}' must be between 1 and {MAX_FRAMES}", number)
    number, tokens = lines.next()
    if tokens[:2] != ["Frame", "Time:"]:
        raise lines.error("expected 'Frame Time: seconds'", number)
    (frame_time,) = _floats(lines, tokens[2:], 1, number)
    if not MIN_FRAME_TIME <= frame_time <= MAX_FRAME_TIME:
        raise lines.error(f"frame time must be in [{MIN_FRAME_TIME:g}, {MAX_FRAME_TIME:g}] seconds", number)
    width = skeleton.channel_count
    if width > MAX_CHANNELS:
        raise lines.error(f"{width} channels; the limit is {MAX_CHANNELS}", number)
    numbers = [n + 1 for n in range(lines.position, len(lines.raw)) if lines.raw[n].strip()]
    if len(numbers) != frame_count:
        where = numbers[-1] if numbers else number
        raise lines.error(f"{len(numbers)} frame lines but 'Frames: {frame_count}'", where)
    try:  # fast path: numpy's C parser
        values = np.loadtxt([lines.raw[n - 1] for n in numbers], dtype=np.float64, ndmin=2)
    except ValueError:
        values = np.empty((0, 0))
    if values.shape != (frame_count, width):  # find the offending line for the message
        for line_number in numbers:
            row_tokens = lines.raw[line_number - 1].split()
            if len(row_tokens) != width:
                raise lines.error(f"{len(row_tokens)} values, the hierarchy has {width}", line_number)
            _floats(lines, row_tokens, width, line_number)
        if frame_count:
            raise lines.error("unreadable frames")
        values = np.empty((0, width))
    if not np.all(np.isfinite(values)):
        bad = int(np.argwhere(~np.isfinite(values))[0][0])
        raise lines.error("non-finite value", numbers[bad])
    if values.size and float(np.abs(values).max()) > MAX_CHANNEL_VALUE:
        bad = int(np.argwhere(np.abs(values) > MAX_CHANNEL_VALUE)[0][0])
        raise lines.error(f"a value beyond +-{MAX_CHANNEL_VALUE:g}", numbers[bad])
    return Motion(skeleton, frame_time, values)


def _is_count(token: str) -> bool:
    return token.isascii() and token.isdigit() and len(token) <= 9


def read_bvh(path: str | os.PathLike[str]) -> Motion:
    """Read a BVH file; unreadable or malformed files raise MseError (E100)."""
    name = os.fspath(path)
    data = read_input(name, limit=MAX_BVH_BYTES, what="BVH")  # regular files only, size-capped
    return parse_bvh(data.decode("utf-8", errors="replace"), name)


# -- writing ------------------------------------------------------------------------------
def _number(value: float) -> str:
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") else text


def format_bvh(motion: Motion) -> str:
    """The BVH text of ``motion`` (tabs for indentation, ``repr`` precision)."""
    skeleton = motion.skeleton
    out = ["HIERARCHY"]

    def emit(joint: int, depth: int) -> None:
        pad = "\t" * depth
        keyword = "ROOT" if skeleton.parents[joint] < 0 else "JOINT"
        out.append(f"{pad}{keyword} {skeleton.names[joint]}")
        out.append(pad + "{")
        out.append(f"{pad}\tOFFSET " + " ".join(_number(v) for v in skeleton.offsets[joint]))
        joint_channels = skeleton.channels[joint]
        out.append(f"{pad}\tCHANNELS {len(joint_channels)} " + " ".join(joint_channels))
        for child in skeleton.children(joint):
            emit(child, depth + 1)
        end = skeleton.end_sites[joint]
        if end is not None:
            out.extend([f"{pad}\tEnd Site", pad + "\t{"])
            out.append(f"{pad}\t\tOFFSET " + " ".join(_number(v) for v in end))
            out.append(pad + "\t}")
        out.append(pad + "}")

    for root in (j for j, p in enumerate(skeleton.parents) if p < 0):
        emit(root, 0)
    out.append("MOTION")
    out.append(f"Frames: {motion.frame_count}")
    out.append(f"Frame Time: {_number(motion.frame_time)}")
    out.extend(" ".join(map(_number, row)) for row in motion.values.tolist())
    return "\n".join(out) + "\n"


def write_bvh(path: str | os.PathLike[str], motion: Motion) -> None:
    """Write ``motion`` to ``path`` atomically."""
    write_atomic(path, format_bvh(motion))
