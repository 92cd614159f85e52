"""Diagnostics: small immutable records with a code and a source position.

Every layer reports problems as :class:`Diagnostic` records; front-ends (the CLI, an
editor, CI) decide how to render them.  Codes: ``E1xx`` unreadable input (``E130``: a bad
argument or option value; ``E15x``: dialogue inputs), ``E2xx`` semantics, ``W3xx`` static
lint, ``E4xx``/``W4xx``/``N4xx`` solver-backed lint (``N``: notes, never counted by
``--strict``), ``W5xx`` import/conversion notes, ``W6xx`` export notes, ``W7xx``/``E7xx``
repair notes.
"""

from __future__ import annotations

import enum
from collections.abc import Iterable
from dataclasses import dataclass


class Severity(enum.Enum):
    ERROR = "error"
    WARNING = "warning"
    #: A fact worth knowing that may well be what the author meant (N codes): shown, never
    #: counted by ``--strict``.
    NOTE = "note"


@dataclass(frozen=True, slots=True)
class Span:
    """A position in a source file: 1-based line and column, optional end."""

    path: str
    line: int = 0
    col: int = 0
    end_line: int | None = None
    end_col: int | None = None

    def render(self) -> str:
        if self.line <= 0:
            return self.path
        return f"{self.path}:{self.line}:{self.col}"


#: One table from code to meaning (the title used by SARIF and ``--select`` docs).
CODES: dict[str, str] = {
    # E1xx: the file cannot be read as MSE syntax
    "E100": "file cannot be read",
    "E101": "XML is not well-formed",
    "E102": "XML schema violation",
    "E103": "forbidden XML construct (DTD entities, external entities)",
    "E104": "file too large",
    "E105": "output cannot be written (unwritable or refused target)",
    "E110": "constraint expression syntax error",
    "E111": "constraint expression nested too deeply",
    "E112": "invalid number",
    "E120": "annotation file cannot be read (ELAN, CSV/TSV)",
    "E121": "invalid annotation",
    "E122": "corpus beyond the limits of learn (sequence length, distinct signals, annotations)",
    # E130: the command line or a library call asked for something invalid
    "E130": "invalid argument or option value",
    "E150": "FML-APML or EmotionML structure mse cannot read",
    "E151": "time reference that names nothing, or times on different bases",
    "E152": "invalid number or time in an FML-APML or EmotionML input",
    # E2xx: well-formed but meaningless
    "E201": "duplicate signal id",
    "E202": "duplicate constraint id",
    "E203": "unknown signal in a constraint",
    "E204": "invalid signal attribute value",
    "E205": "min_duration greater than max_duration",
    "E206": "probability outside [0, 1]",
    "E207": "repetitivity is not 0 or 1",
    "E208": "negative tolerance",
    "E209": "empty signal set",
    "E210": "invalid identifier",
    "E211": "duplicate modality declaration",
    "E212": "invalid timeline",
    "E213": "invalid motion leaf",
    "E214": "invalid lexeme table",
    "E215": "time outside the supported range",
    "E216": "a signal's length compared with something other than a number",
    "E217": "invalid dialogue script (event, order, utterance or word timing)",
    "E218": "invalid repair proposal (structure, names, times, word timings)",
    "E219": "speech anchor with no speech given (speech.start, speech.stop, stressed)",
    "E220": "invalid speech (structure, times, word timing, stressed words)",
    # W3xx: static lint
    "W300": "no behaviour-set file found",
    "W301": "inactive signal (both probabilities are 0)",
    # W302 (a signal shorter than the sampler's time slot) is retired: the walk places and
    # times short signals at their profile's rate whatever --slot is (measured 0.39-0.39
    # occurrences of a 0.5/0.5 0.2-0.4 s signal at slots 1, 0.2 and 0.05 s); kept so that
    # --select/--ignore W302 in a user's CI still names a code.
    "W302": "retired (never reported): signal shorter than the sampler's time slot",
    "W303": "relation of a signal with itself",
    "W304": "constraint whose trigger signals can never occur",
    "W305": "duplicate constraint",
    "W306": "lexeme class contradicts the modality",
    "W307": "unknown modality",
    "W308": "lexeme the realizer cannot resolve",
    "W309": "time finer than the 1 ms grid (rounded)",
    "W310": "motion action unknown to the starter library",
    "W311": "max_occurrences without repetitivity=\"1\"",
    "W312": "exclusive modality that no signal uses",
    "N313": "constraint anchored to the agent's speech (sampling and checking need speech)",
    # E4xx / W4xx: solver-backed lint
    "W400": "solver-backed questions left undecided (lint time budget spent)",
    "E401": "no consistent timeline (proven, with a minimal explanation)",
    "W401": "no consistent timeline found (undecided, or not proven)",
    "W402": "dead signal",
    "W403": "constraint never instantiated",
    "W404": "redundant constraint",
    "W405": "signal forced by the constraints",
    "W406": "probability profile contradicted by the constraints",
    # N4xx: solver-backed notes
    "N407": "relation void in most sampled timelines that show one of its signals",
    # W5xx: import and conversion
    "W501": "Greta name mismatch resolved",
    "W502": "Greta construct approximated",
    "W503": "annotation left out or merged",
    "W520": "input element mse does not use (FML function, prosody, EmotionML descriptor)",
    "W521": "input attribute mse does not use",
    "W522": "input emotion with no behaviour set",
    "W523": "overlapping input emotions cut (one emotion at a time)",
    "W524": "input times estimated or shifted",
    "W525": "several categories in one emotion (the strongest is played)",
    "W526": "input emotion without a usable time (not placed)",
    "W527": "FML function Greta's reader drops",
    "W528": "input with no emotion mse can play",
    "W529": "emotion vocabulary mse does not know (names not checked)",
    # W6xx: export
    "W601": "behaviour left out of the export (the realizer cannot play it)",
    "W602": "lexeme not drawn by the face player",
    "W603": "BML behaviour written with a lexeme outside BML 1.0's core sets",
    # W7xx / E7xx: repair of proposed expressions
    "W701": "proposed occurrence naming no signal of the set (left out of the repair)",
    "E702": "no repair keeps what must be kept (proven, with a minimal explanation)",
}


@dataclass(frozen=True, slots=True)
class Diagnostic:
    """One problem found in one place."""

    code: str
    message: str
    span: Span

    @property
    def severity(self) -> Severity:
        if self.code.startswith("E"):
            return Severity.ERROR
        return Severity.NOTE if self.code.startswith("N") else Severity.WARNING

    @property
    def is_error(self) -> bool:
        return self.severity is Severity.ERROR

    def render(self) -> str:
        return f"{self.span.render()}: {self.code} {self.message}"

    def sort_key(self) -> tuple[str, int, int, str]:
        return (self.span.path, self.span.line, self.span.col, self.code)


class MseError(Exception):
    """Raised by library entry points when input has errors; carries every diagnostic."""

    def __init__(self, diagnostics: Iterable[Diagnostic]) -> None:
        self.diagnostics: tuple[Diagnostic, ...] = tuple(sorted(diagnostics, key=Diagnostic.sort_key))
        super().__init__("\n".join(d.render() for d in self.diagnostics))


#: Where argument errors are located: no file, the command's options (or the arguments of a
#: library call); the message names the option.
ARGUMENTS = "<arguments>"


def argument_error(*messages: str) -> MseError:
    """E130 at ``<arguments>``, one diagnostic per message: an option value (or a library
    argument) that is invalid in itself or with the others.  Each message names the option,
    e.g. ``--pin 'x' must look like SIGNAL@START-STOP``."""
    return MseError([Diagnostic("E130", message, Span(ARGUMENTS)) for message in messages])


def has_errors(diagnostics: Iterable[Diagnostic]) -> bool:
    return any(d.is_error for d in diagnostics)
