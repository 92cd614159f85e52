"""Every size, depth and range limit of mse in one place (documented in docs/security.md).

Input is untrusted: a behaviour set, a timeline, an IR file, a motion clip or a library
index may come from anyone.  Each limit is checked where the input enters (the reader or
the builder of the IR), before any solver, exporter or motion generator sees a value, so
that bad input gets a located E-code instead of a traceback, a hang or unbounded memory.
"""

from __future__ import annotations

import math
import re

# -- sizes of whole inputs ------------------------------------------------------------------
#: Behaviour-set XML files, Greta files, compiled IR JSON, timelines, library indexes.
MAX_INPUT_BYTES = 10 * 1024 * 1024
#: BVH clips (the largest real clip in the reference data is 2.4 MB).
MAX_BVH_BYTES = 32 * 1024 * 1024
#: HSMM model archives (.avg/.sad ...), compressed and after decompression.
MAX_MODEL_BYTES = 64 * 1024 * 1024
#: One CSV field of a library index.
MAX_CSV_FIELD = 4096

# -- structure ----------------------------------------------------------------------------
#: JSON nesting (objects and arrays).  Compiled IR nests two levels per level of a
#: constraint (at most 200, E111), so mse's own files stay under about 410.
MAX_JSON_DEPTH = 500
#: Digits of one JSON integer (Python refuses more than 4300 anyway).
MAX_JSON_INT_DIGITS = 20
#: Elements of one behaviour-set file, and signals (10x the largest sets the solvers are
#: measured on; a 10 MB file of signals would otherwise take seconds per stage).
MAX_ELEMENTS = 20_000
MAX_SIGNALS = 2_000
#: Characters of one name read from data: a learned signal id or modality, a timeline's
#: signal id, modality or lexeme (longer ones are no names, and cost memory to draw).
MAX_NAME_CHARS = 256
#: Characters of a file path read from data (a timeline's motion clip).
MAX_PATH_CHARS = 4096
#: Distinct signals and annotations ``mse learn`` mines (every pair of signals is tested in
#: every sequence: 300 signals take about 8 s, 1,000 about a minute).
MAX_LEARN_SIGNALS = 300
MAX_LEARN_ANNOTATIONS = 100_000
#: Elements of any other XML input (Greta files, face libraries).
MAX_XML_ELEMENTS = 200_000
#: Characters of one constraint expression (its text content).
MAX_CONSTRAINT_CHARS = 100_000
#: Characters of all constraints of one file together (parsing takes about 4 us each).
MAX_CONSTRAINT_TEXT = 500_000

# -- times ----------------------------------------------------------------------------------
#: Every time in seconds (durations of signals, constants and offsets in constraints,
#: tolerances, timeline starts, stops and durations) must lie in [-MAX_SECONDS, MAX_SECONDS]
#: (durations in [0, MAX_SECONDS]).  10^6 s is 11.6 days: on the 1 ms grid that is 10^9
#: ticks, far inside every solver's integer range, and sums of a few such values stay exact.
MAX_SECONDS = 1_000_000.0
#: The smallest timeline duration: one tick of the 1 ms grid.
MIN_DURATION_SECONDS = 0.001
#: The longest timeline a solver is asked for (``sample --duration``, ``lint --duration``).
MAX_SOLVE_SECONDS = 3600.0


def solve_duration_problem(value: float) -> str | None:
    """Why ``value`` is not a duration a solver may be asked for, or None."""
    if not MIN_DURATION_SECONDS <= value <= MAX_SOLVE_SECONDS:  # NaN fails too
        return f"must be in [{MIN_DURATION_SECONDS:g}, {MAX_SOLVE_SECONDS:g}] seconds (the 1 ms grid)"
    return None

# -- motion -------------------------------------------------------------------------------
#: Longest motion generated for one occurrence or one ``style synth`` clip (seconds).
MAX_MOTION_SECONDS = 600.0
#: Longest timeline ``animate`` composes into timeline.bvh, and the longest total of its
#: motion occurrences (seconds): about 1.1 GB and 90 s on the CI machine at the limit.
MAX_ANIMATE_SECONDS = 3600.0
#: Steps of a cyclic ``style synth`` clip.
MAX_STEPS = 1000
#: Frame times accepted in BVH files and motion models (seconds).
MIN_FRAME_TIME = 1e-4
MAX_FRAME_TIME = 10.0
#: Frames of one BVH clip, and channels of its skeleton.
MAX_FRAMES = 1_000_000
MAX_CHANNELS = 10_000
#: Absolute value of any channel value (cm or degrees) in a BVH clip.
MAX_CHANNEL_VALUE = 1e7

# XSD xs:decimal / xs:double lexical forms, ASCII digits only (Python's float() also takes
# "1_0", Arabic-Indic digits, "inf" and surrounding Unicode spaces; the schema does not).
_DOUBLE = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_INTEGER = re.compile(r"[+-]?[0-9]+")
#: XML's whitespace (the schema's ``collapse``): not Unicode's.
XML_SPACE = " \t\r\n"


def parse_double(text: str) -> float | None:
    """The value of ``text`` if it is an xs:double literal with ASCII digits (surrounding
    XML whitespace allowed; INF and NaN refused), else None.  The exponent is bounded so
    that the conversion stays cheap; out-of-range values come back as inf."""
    stripped = text.strip(XML_SPACE)
    if len(stripped) > 400 or not _DOUBLE.fullmatch(stripped):
        return None
    value = float(stripped)
    return value if not math.isnan(value) else None


def parse_integer(text: str, *, max_digits: int = 9) -> int | None:
    """The value of an xs:integer literal with ASCII digits and at most ``max_digits``
    digits, else None."""
    stripped = text.strip(XML_SPACE)
    if not _INTEGER.fullmatch(stripped) or len(stripped.lstrip("+-")) > max_digits:
        return None
    return int(stripped)


def time_problem(value: float, *, minimum: float = -MAX_SECONDS) -> str | None:
    """Why ``value`` (seconds) is not a supported time, or None."""
    if not math.isfinite(value):
        return "is not a finite number"
    if value < minimum or value > MAX_SECONDS:
        low = "0" if minimum == 0 else f"{minimum:g}"
        return f"is outside the supported range [{low}, {MAX_SECONDS:g}] seconds"
    return None


# -- text -----------------------------------------------------------------------------------
#: Characters XML 1.0 cannot hold (C0 controls but tab and line ends, lone surrogates,
#: U+FFFE/U+FFFF).  Text that reaches BML, SVG or HTML must not contain them.
_NOT_XML_CHAR = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def xml_char_problem(text: str) -> str | None:
    """Why ``text`` cannot appear in an XML document (its first bad character), or None."""
    match = _NOT_XML_CHAR.search(text)
    if match is None:
        return None
    return f"contains the character U+{ord(match.group()):04X}, which XML cannot hold"


def xml_safe(text: str) -> str:
    """``text`` with every character XML cannot hold replaced by U+FFFD."""
    return _NOT_XML_CHAR.sub("\ufffd", text)
