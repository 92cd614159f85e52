"""Speech anchors: the agent's speech put into a model's constraints before solving.

``speech.start``, ``speech.stop``, ``stressed`` and ``stressed.stop`` (:class:`~mse.ir.model.SpeechTime`)
are times known only with the request: :func:`resolve_anchors` rewrites them into constants, so
that both solvers and the one evaluator work on the resolved model unchanged (a model
transformation, as CPMpy does it).  The meaning is docs/semantics.md, "Speech anchors":

- ``speech.start`` / ``speech.stop`` are the utterance's start and stop (with several utterances
  in one expression, the first one's start and the last one's stop);
- a comparison naming ``stressed`` (or ``stressed.stop``) holds when it holds for *some*
  stressed word: it becomes an ``or`` over the stressed words, one word per comparison (both
  sides of one comparison read the same word);
- with no stressed word, such a comparison is false (the ``or`` of nothing), kept as a
  comparison that is false whenever its signals occur, so the constraint is instantiated
  exactly as before.

Times are seconds in the expression's own time (0 is the expression's start).
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from mse.diagnostics import Diagnostic, MseError, Span
from mse.input_files import read_json
from mse.ir import model as ir
from mse.ir.printer import term_text
from mse.ir.schedule import to_ticks
from mse.limits import time_problem

#: Invalid speech input.
SPEECH_CODE = "E220"
#: A speech anchor with no speech given.
NO_SPEECH_CODE = "E219"
#: Keys of one utterance (the dialogue timeline's ``utterances`` entries also carry ``text``
#: and ``index``).
UTTERANCE_KEYS = frozenset({"start", "stop", "words", "stress", "text", "index"})


@dataclass(frozen=True, slots=True)
class Word:
    """One spoken word: its text, start and stop (seconds) and whether it is stressed."""

    text: str
    start: float
    stop: float
    stressed: bool = False


@dataclass(frozen=True, slots=True)
class Speech:
    """What the agent says during one expression, in the expression's own time (seconds)."""

    start: float
    stop: float
    words: tuple[Word, ...] = ()

    @property
    def stressed(self) -> tuple[Word, ...]:
        return tuple(word for word in self.words if word.stressed)

    @staticmethod
    def join(utterances: Sequence[Speech]) -> Speech:
        """Several utterances in one expression: the first one's start, the last one's stop,
        every word (so every stressed word)."""
        if not utterances:
            raise ValueError("no utterance to join")
        ordered = sorted(utterances, key=lambda u: u.start)
        return Speech(
            ordered[0].start,
            max(u.stop for u in ordered),
            tuple(word for u in ordered for word in u.words),
        )


def episode_speech(utterances: Sequence[Speech], start: float, stop: float | None) -> Speech | None:
    """The speech of one episode of a dialogue, ``[start, stop)`` in the dialogue's time
    (``stop`` None: not known yet), in the episode's own time (0 = ``start``): the utterances
    that overlap the episode, joined, every time shifted by ``-start``.  An utterance begun
    before the episode or running past its end keeps its words, whose times may then lie
    before 0 or after the episode (a comparison with them still has its meaning).  None when
    no utterance overlaps (anchors of the episode's set are then an error, E219)."""
    inside = [u for u in utterances if u.stop > start and (stop is None or u.start < stop)]
    if not inside:
        return None
    def moved(time: float) -> float:  # on the 1 ms grid, as every time of a timeline
        return to_ticks(time - start) / 1000

    shifted = [
        Speech(moved(u.start), moved(u.stop),
               tuple(replace(w, start=moved(w.start), stop=moved(w.stop)) for w in u.words))
        for u in inside
    ]
    return Speech.join(shifted)


# -- resolving ------------------------------------------------------------------------------------
def term_anchors(term: ir.Term) -> bool:
    return isinstance(term, ir.SpeechTime)


def anchored_atoms(expr: ir.Expr) -> Iterator[ir.Compare]:
    """The comparisons of ``expr`` that name a speech anchor."""
    for node in ir.walk(expr):
        if isinstance(node, ir.Compare) and (term_anchors(node.left) or term_anchors(node.right)):
            yield node


def anchored_constraints(model: ir.Model) -> list[ir.Constraint]:
    # A live session asks this of the same model several times per episode: read once per
    # tuple of constraints (identity; the entry holds the tuple, so its id is not reused).
    constraints = model.constraints
    entry = _ANCHORED.get(id(constraints))
    if entry is None or entry[0] is not constraints:
        if len(_ANCHORED) >= _ANCHORED_LIMIT:
            _ANCHORED.clear()
        found = tuple(c for c in constraints if next(anchored_atoms(c.expr), None) is not None)
        entry = _ANCHORED[id(constraints)] = (constraints, found)
    return list(entry[1])


_ANCHORED: dict[int, tuple[tuple[ir.Constraint, ...], tuple[ir.Constraint, ...]]] = {}
_ANCHORED_LIMIT = 1024


def uses_anchors(model: ir.Model) -> bool:
    return bool(anchored_constraints(model))


def without_anchored(model: ir.Model) -> ir.Model:
    """``model`` without its anchored constraints: what can be asked of it with no speech
    (solver-backed lint, which has no request; the N313 note says which were left out)."""
    anchored = anchored_constraints(model)
    if not anchored:
        return model
    return replace(model, constraints=tuple(c for c in model.constraints if c not in anchored))


def episode_model(model: ir.Model, utterances: Sequence[Speech], start: float, stop: float | None) -> ir.Model:
    """The model one dialogue episode ``[start, stop)`` is planned and checked with: its
    anchors resolved against those of ``utterances`` that overlap it (:func:`episode_speech`).
    When none does, the anchored constraints have nothing to hold on and are left out, as a
    relation is void while its signal is absent (docs/semantics.md, "Speech anchors in a
    dialogue").  A live session passes what was said by the episode's start and records it in
    the episode's ``speech`` (utterance indices), which the checker then reads."""
    if not uses_anchors(model):
        return model
    speech = episode_speech(utterances, start, stop)
    return resolve_anchors(model, speech) if speech is not None else without_anchored(model)


def _first_anchor(atom: ir.Compare) -> ir.SpeechTime:
    term = atom.left if isinstance(atom.left, ir.SpeechTime) else atom.right
    assert isinstance(term, ir.SpeechTime)
    return term


def no_speech_error(model: ir.Model) -> MseError:
    """E219 at each constraint that names an anchor (its first anchor's position)."""
    diagnostics = []
    for constraint in anchored_constraints(model):
        term = _first_anchor(next(anchored_atoms(constraint.expr)))
        diagnostics.append(Diagnostic(
            NO_SPEECH_CODE,
            f"constraint {constraint.id!r} refers to the agent's speech ({term_text(term)}), but no speech "
            "was given: pass --speech FILE (mse sample, mse check), a timeline with 'utterances', or "
            "call mse.ir.anchors.resolve_anchors(model, speech)",
            term.span if term.span.line > 0 else constraint.span,
        ))
    return MseError(diagnostics)


def resolve_anchors(model: ir.Model, speech: Speech | None) -> ir.Model:
    """``model`` with every speech anchor replaced by the times of ``speech``.

    A model without anchors is returned as it is (the same object).  Anchors with
    ``speech=None`` raise :class:`MseError` E219 at each constraint that names one."""
    if not uses_anchors(model):
        return model
    if speech is None:
        raise no_speech_error(model)
    resolver = _Resolver(speech)
    constraints = tuple(
        replace(c, expr=resolver.expr(c.expr)) if next(anchored_atoms(c.expr), None) is not None else c
        for c in model.constraints
    )
    return replace(model, constraints=constraints)


class _Resolver:
    def __init__(self, speech: Speech) -> None:
        self.start = to_ticks(speech.start)
        self.stop = to_ticks(speech.stop)
        self.stressed = [(to_ticks(w.start), to_ticks(w.stop)) for w in speech.stressed]

    def expr(self, expr: ir.Expr) -> ir.Expr:
        if isinstance(expr, ir.Not):
            return ir.Not(self.expr(expr.operand), expr.span)
        if isinstance(expr, ir.And | ir.Or):
            return type(expr)(tuple(self.expr(e) for e in expr.operands), expr.span)
        if isinstance(expr, ir.Implies):
            return ir.Implies(self.expr(expr.left), self.expr(expr.right), expr.span)
        if isinstance(expr, ir.Compare):
            return self.compare(expr)
        return expr

    def compare(self, atom: ir.Compare) -> ir.Expr:
        if not (term_anchors(atom.left) or term_anchors(atom.right)):
            return atom
        names_stress = any(
            isinstance(t, ir.SpeechTime) and t.anchor.startswith("stressed") for t in (atom.left, atom.right)
        )
        if not names_stress:
            return replace(atom, left=self.term(atom.left, None), right=self.term(atom.right, None))
        if not self.stressed:
            return _false_like(atom)
        choices = [
            replace(atom, left=self.term(atom.left, word), right=self.term(atom.right, word))
            for word in self.stressed
        ]
        return choices[0] if len(choices) == 1 else ir.Or(tuple(choices), atom.span)

    def term(self, term: ir.Term, word: tuple[int, int] | None) -> ir.Term:
        if not isinstance(term, ir.SpeechTime):
            return term
        if term.anchor == "start":
            base = self.start
        elif term.anchor == "stop":
            base = self.stop
        else:
            assert word is not None
            base = word[0] if term.anchor == "stressed_start" else word[1]
        return ir.Constant(base + term.offset, term.span)


def _false_like(atom: ir.Compare) -> ir.Compare:
    """A comparison that is false whenever the signals of ``atom`` occur and, like ``atom``,
    unknown when one does not: ``start(s) < start(s)``, or ``0 < 0`` without a signal."""
    signal = next((t for t in (atom.left, atom.right) if isinstance(t, ir.SignalTime)), None)
    same: ir.Term = ir.SignalTime(signal.signal, "start", 0, atom.span) if signal else ir.Constant(0, atom.span)
    return ir.Compare("<", same, same, 0, atom.span)


def timeline_speech(model: ir.Model, timeline: Any, speech: Speech | None, path: str) -> ir.Model:
    """``model`` resolved for checking ``timeline`` (a :class:`mse.timeline.Timeline`, read
    from ``path``): with ``speech`` when given, else with the timeline's own ``utterances``."""
    if not uses_anchors(model):
        return model
    if speech is None and "utterances" in timeline.extra:
        speech = speech_from_utterances(timeline.extra["utterances"], Span("<stdin>" if path == "-" else path))
    return resolve_anchors(model, speech)


# -- reading speech -------------------------------------------------------------------------------
def _fail(message: str, span: Span) -> MseError:
    return MseError([Diagnostic(SPEECH_CODE, message, span)])


def _bare(word: str) -> str:
    """A word without surrounding punctuation ("that," -> "that")."""
    return word.strip(".,;:!?\"'()[]{}«»“”‘’…-")


def _seconds(value: Any, what: str, span: Span) -> float:
    if not isinstance(value, int | float) or isinstance(value, bool) or not math.isfinite(value):
        raise _fail(f"{what} must be a number of seconds, not {value!r}", span)
    problem = time_problem(float(value))
    if problem is not None or value < 0:
        raise _fail(f"{what} {value:g} {problem or 'is negative'}", span)
    return float(value)


def _words(raw: Any, where: str, span: Span) -> list[Word]:
    if not isinstance(raw, list):
        raise _fail(f"{where}'words' must be a list of [word, start, stop]", span)
    words: list[Word] = []
    for index, entry in enumerate(raw):
        if not isinstance(entry, list) or len(entry) != 3 or not isinstance(entry[0], str):
            raise _fail(f"{where}words[{index}] must be [word, start, stop] (a string and two numbers), "
                        f"not {entry!r}", span)
        start = _seconds(entry[1], f"{where}words[{index}] start", span)
        stop = _seconds(entry[2], f"{where}words[{index}] stop", span)
        if stop < start:
            raise _fail(f"{where}words[{index}] ({entry[0]!r}) stops at {stop:g} s, before its start {start:g} s", span)
        if words and start < words[-1].stop:
            raise _fail(f"{where}words[{index}] ({entry[0]!r}) starts at {start:g} s, before the previous word "
                        f"stops at {words[-1].stop:g} s: words are in order and do not overlap", span)
        words.append(Word(entry[0], start, stop))
    return words


def utterance_from_json(obj: Any, span: Span, where: str = "") -> Speech:
    """One utterance ``{"start", "stop", "words": [[w, start, stop], ...], "stress": [w, ...]}``
    (``start``/``stop`` default to the first word's start and the last word's stop); E220 at
    ``span`` with what is wrong otherwise."""
    if not isinstance(obj, dict):
        raise _fail(f"{where}speech must be a JSON object such as "
                    '{"start": 0.4, "stop": 2.0, "words": [["I", 0.4, 0.52]], "stress": ["I"]}', span)
    for key in obj:
        if key not in UTTERANCE_KEYS:
            guess = difflib.get_close_matches(str(key), sorted(UTTERANCE_KEYS), n=1, cutoff=0.6)
            hint = f" (did you mean {guess[0]!r}?)" if guess else ""
            raise _fail(f"{where}unknown key {key!r} in speech{hint}; allowed: {', '.join(sorted(UTTERANCE_KEYS))}",
                        span)
    words = _words(obj.get("words", []), where, span)
    if "start" not in obj and not words:
        raise _fail(f"{where}speech needs 'start' (seconds) or 'words'", span)
    start = _seconds(obj["start"], f"{where}'start'", span) if "start" in obj else words[0].start
    stop = _seconds(obj["stop"], f"{where}'stop'", span) if "stop" in obj else (words[-1].stop if words else start)
    if stop < start:
        raise _fail(f"{where}'stop' {stop:g} s is before 'start' {start:g} s", span)
    for index, word in enumerate(words):
        if word.start < start or word.stop > stop:
            raise _fail(f"{where}words[{index}] ({word.text!r}, {word.start:g}-{word.stop:g} s) lies outside "
                        f"the utterance ({start:g}-{stop:g} s)", span)
    stress = obj.get("stress", [])
    if not isinstance(stress, list) or not all(isinstance(s, str) for s in stress):
        raise _fail(f"{where}'stress' must be a list of words of the utterance", span)
    spoken = {_bare(w.text).casefold() for w in words} | {w.text.casefold() for w in words}
    for marked in stress:
        if marked.casefold() not in spoken:
            guess = difflib.get_close_matches(marked, sorted({w.text for w in words}), n=1, cutoff=0.6)
            hint = f" (did you mean {guess[0]!r}?)" if guess else ""
            raise _fail(f"{where}stressed word {marked!r} is not among the utterance's words{hint}", span)
    marks = {s.casefold() for s in stress}
    marked_words = tuple(
        replace(w, stressed=_bare(w.text).casefold() in marks or w.text.casefold() in marks) for w in words
    )
    return Speech(start, stop, marked_words)


def utterances_from_json(raw: Any, span: Span) -> list[Speech]:
    """A timeline's ``utterances`` (the dialogue format), one :class:`Speech` each."""
    if not isinstance(raw, list):
        raise _fail("'utterances' must be a list of utterances", span)
    return [utterance_from_json(u, span, f"utterances[{i}]: ") for i, u in enumerate(raw)]


def speech_from_utterances(raw: Any, span: Span) -> Speech | None:
    """A timeline's ``utterances``, joined; None for an empty list."""
    utterances = utterances_from_json(raw, span)
    return Speech.join(utterances) if utterances else None


def read_speech(path: str | Path) -> Speech:
    """The speech file of ``--speech``: one utterance object, or ``{"utterances": [...]}``."""
    span = Span("<stdin>" if str(path) == "-" else str(path))
    obj = read_json(path, what="speech file", code=SPEECH_CODE)
    if isinstance(obj, dict) and set(obj) == {"utterances"}:
        speech = speech_from_utterances(obj["utterances"], span)
        if speech is None:
            raise _fail("'utterances' is empty", span)
        return speech
    return utterance_from_json(obj, span)
