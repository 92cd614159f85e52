"""Reading a proposal in any of its three forms (docs/repair.md):

* a **timeline** (``mse-timeline/1``, as ``mse sample --format json`` writes it);
* a **light proposal** (``mse-proposal/1``, JSON Schema ``proposal.schema.json`` beside this
  module): occurrences by signal id or lexeme, with times, or only in order with rough
  lengths, optional weights; or tagged text with its words' times;
* **tagged text** (``[nod] I [smile]really[/smile] mean it``), its words' times estimated at
  :data:`CHARS_PER_SECOND`.

A document starting with ``{`` is JSON, anything else is tagged text.  Every problem is an
:class:`~mse.diagnostics.MseError` with code E218 at ``path:line:col``.  A name the set does not
know is no error: that occurrence is *foreign* (reported, kept out of the solve).
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from mse.diagnostics import Diagnostic, MseError, Span
from mse.ir import model as ir
from mse.ir.schedule import to_ticks
from mse.limits import MAX_SOLVE_SECONDS, MIN_DURATION_SECONDS, time_problem
from mse.repairing.positions import Path, Positions, json_positions
from mse.repairing.proposal import MAX_PROPOSED, MAX_WEIGHT, Form, Proposal, ProposedOccurrence, typical_length

if TYPE_CHECKING:
    from mse.timeline import Timeline

CODE = "E218"
PROPOSAL_FORMAT = "mse-proposal/1"
TIMELINE_FORMAT = "mse-timeline/1"
#: Speaking rate for text without word times: characters per second, a word's space included
#: (about 165 words a minute for English words of five letters, an ordinary TTS rate).
CHARS_PER_SECOND = 14.0

_TOP_KEYS = frozenset({"format", "expression", "duration", "occurrences", "text", "words"})
_OCCURRENCE_KEYS = frozenset({"signal", "lexeme", "start", "stop", "length", "weight", "keep", "fixed", "id"})
_TAG = re.compile(r"\[(/?)([^\[\]\s/]+)\]")


def proposal_schema() -> dict[str, Any]:
    """The JSON Schema of ``mse-proposal/1`` (``proposal.schema.json`` beside this module)."""
    import json
    from importlib.resources import files

    schema: dict[str, Any] = json.loads(files("mse.repairing").joinpath("proposal.schema.json").read_text("utf-8"))
    return schema


class _Located:
    """Positions of one document's values, and errors raised at them."""

    def __init__(self, path: str, positions: Positions | None) -> None:
        self.path = path
        self.positions = positions

    def span(self, where: Path = ()) -> Span:
        """The value's line:col; just the path when the JSON came decoded (no positions)."""
        if self.positions is None:
            return Span(self.path)
        line, col = self.positions.of(where)
        return Span(self.path, line, col)

    def fail(self, message: str, where: Path = ()) -> MseError:
        return MseError([Diagnostic(CODE, message, self.span(where))])


def read_proposal(model: ir.Model, text: str, *, path: str = "<proposal>", duration: float | None = None) -> Proposal:
    """The proposal in ``text`` (any form) for ``model``; ``duration`` (seconds) is used when
    the proposal gives none (a timeline always gives its own)."""
    from mse.input_files import parse_json

    if text.lstrip().startswith("{"):
        decoded = parse_json(text, path, code=CODE)
        located = _Located(path, json_positions(text))
        proposal = from_json(model, decoded, located=located, duration=duration)
    else:
        proposal = _from_text(model, text, None, _Located(path, None), duration, line_text=text)
    return _replace_text(proposal, text)


def from_json(model: ir.Model, obj: Any, *, path: str = "<proposal>", duration: float | None = None,
              located: _Located | None = None, timeline: Timeline | None = None) -> Proposal:
    """A proposal from decoded JSON (a timeline or a light proposal); ``timeline``: the
    timeline ``obj`` was written from, when there is one (returned as it is when consistent)."""
    at = located or _Located(path, None)
    if not isinstance(obj, dict):
        raise at.fail("a proposal must be a JSON object (a timeline or an mse-proposal/1 document)")
    fmt = obj.get("format")
    if fmt == TIMELINE_FORMAT or (fmt is None and "signals" in obj):
        return _from_timeline(model, obj, at, duration, timeline)
    if fmt not in (None, PROPOSAL_FORMAT):
        raise at.fail(f"unknown format {fmt!r} (expected {PROPOSAL_FORMAT!r} or {TIMELINE_FORMAT!r})", ("format",))
    unknown = sorted(set(obj) - _TOP_KEYS)
    if unknown:
        raise at.fail(f"unknown key {unknown[0]!r} (known: {', '.join(sorted(_TOP_KEYS))})", (unknown[0],))
    expression = obj.get("expression", "")
    if not isinstance(expression, str):
        raise at.fail("'expression' must be a string", ("expression",))
    given = _duration(obj, at) if "duration" in obj else duration
    if ("occurrences" in obj) == ("text" in obj):
        raise at.fail("a proposal holds either 'occurrences' or 'text' (with optional 'words')")
    if "words" in obj and "text" not in obj:
        raise at.fail("'words' goes with 'text'", ("words",))
    if "text" in obj:
        if not isinstance(obj["text"], str):
            raise at.fail("'text' must be a string", ("text",))
        proposal = _from_text(model, obj["text"], obj.get("words"), at, given, line_text=None)
        return _with_expression(proposal, expression)
    raw = obj["occurrences"]
    if not isinstance(raw, list):
        raise at.fail("'occurrences' must be a list", ("occurrences",))
    if len(raw) > MAX_PROPOSED:
        raise at.fail(f"{len(raw)} occurrences; a proposal holds at most {MAX_PROPOSED}", ("occurrences",))
    occurrences = _light_occurrences(model, raw, at)
    return _finish(model, occurrences, given, at, form="proposal", expression=expression)


# -- the timeline form --------------------------------------------------------------------
def _from_timeline(model: ir.Model, obj: dict[str, Any], at: _Located, duration: float | None,
                   timeline: Timeline | None) -> Proposal:
    from mse.timeline import Timeline

    given = _duration(obj, at)
    if duration is not None and to_ticks(duration) != to_ticks(given):
        raise MseError([Diagnostic("E100", f"--duration {duration:g} differs from the timeline's own duration "
                                           f"{given:g} s", Span("<arguments>"))])
    raw = obj.get("signals")
    if not isinstance(raw, list):
        raise at.fail("'signals' must be a list", ("signals",))
    if len(raw) > MAX_PROPOSED:
        raise at.fail(f"{len(raw)} signals; a proposal holds at most {MAX_PROPOSED}", ("signals",))
    occurrences = []
    for index, entry in enumerate(raw):
        where: Path = ("signals", index)
        if not isinstance(entry, dict):
            raise at.fail(f"signals[{index}] must be an object", where)
        name = entry.get("id")
        if not isinstance(name, str):
            raise at.fail(f"signals[{index}] needs a string 'id'", (*where, "id"))
        start = _time(entry, "start", at, where, required=True)
        stop = _time(entry, "stop", at, where, required=True)
        assert start is not None and stop is not None
        occurrences.append(_occurrence(name, _resolve(model, name, "signal", at, where), start, stop, at, where))
    proposal = _finish(model, occurrences, given, at, form="timeline", expression=str(obj.get("expression", "")))
    try:
        timeline = timeline or Timeline.from_json(obj, path=at.path)
    except MseError as error:  # what only the timeline reader checks (characters XML cannot hold)
        raise MseError([Diagnostic(CODE, d.message, at.span()) for d in error.diagnostics]) from None
    return Proposal(proposal.duration, proposal.occurrences, "timeline", at.path, proposal.expression, timeline)


# -- the light form -------------------------------------------------------------------------
def _light_occurrences(model: ir.Model, raw: Sequence[Any], at: _Located) -> list[ProposedOccurrence]:
    occurrences: list[ProposedOccurrence] = []
    labels: dict[str, Path] = {}
    previous_stop = 0
    for index, entry in enumerate(raw):
        where: Path = ("occurrences", index)
        if not isinstance(entry, dict):
            raise at.fail(f"occurrences[{index}] must be an object", where)
        unknown = sorted(set(entry) - _OCCURRENCE_KEYS)
        if unknown:
            raise at.fail(f"occurrences[{index}]: unknown key {unknown[0]!r} "
                          f"(known: {', '.join(sorted(_OCCURRENCE_KEYS))})", (*where, unknown[0]))
        if ("signal" in entry) == ("lexeme" in entry):
            raise at.fail(f"occurrences[{index}] names its signal by 'signal' (an id) or by 'lexeme', "
                          "exactly one of them", where)
        by = "signal" if "signal" in entry else "lexeme"
        name = entry[by]
        if not isinstance(name, str) or not name:
            raise at.fail(f"occurrences[{index}].{by} must be a non-empty string", (*where, by))
        start = _time(entry, "start", at, where)
        stop = _time(entry, "stop", at, where)
        length = _time(entry, "length", at, where)
        if length is not None and length <= 0:
            raise at.fail(f"occurrences[{index}].length must be positive", (*where, "length"))
        if start is not None and stop is not None and length is not None and stop - start != length:
            raise at.fail(f"occurrences[{index}]: start, stop and length disagree (give two of them)", where)
        signal = _resolve(model, name, by, at, (*where, by))
        estimated = start is None
        if length is None:
            if start is not None and stop is not None:
                length = stop - start
            else:
                length = typical_length(model.signal(signal)) if signal is not None else 1000
        if start is None:
            # Only an order: it starts when the occurrence before it in the list stops.
            start = stop - length if stop is not None else previous_stop
            estimated = stop is None
        if stop is None:
            stop = start + length
        if start < 0:
            raise at.fail(f"occurrences[{index}] would start at {start / 1000:g} s (its stop minus its length): "
                          "give 'start'", where)
        weight = entry.get("weight", 1)
        if isinstance(weight, bool) or not isinstance(weight, int) or not 1 <= weight <= MAX_WEIGHT:
            raise at.fail(f"occurrences[{index}].weight must be an integer in [1, {MAX_WEIGHT}]", (*where, "weight"))
        flags = {}
        for key in ("keep", "fixed"):
            value = entry.get(key, False)
            if not isinstance(value, bool):
                raise at.fail(f"occurrences[{index}].{key} must be true or false", (*where, key))
            flags[key] = value
        label = entry.get("id")
        if label is not None:
            if not isinstance(label, str) or not label:
                raise at.fail(f"occurrences[{index}].id must be a non-empty string", (*where, "id"))
            if label in labels:
                line, col = at.span(labels[label]).line, at.span(labels[label]).col
                raise at.fail(f"occurrences[{index}]: id {label!r} is already used at {line}:{col}", (*where, "id"))
            labels[label] = (*where, "id")
        _occurrence(name, signal, start, stop, at, where)
        occurrences.append(ProposedOccurrence(name, signal, start, stop, weight, flags["keep"], flags["fixed"],
                                              label, estimated, at.span(where)))
        previous_stop = stop
    return occurrences


# -- the text form ----------------------------------------------------------------------------
def _from_text(model: ir.Model, text: str, words: Any, at: _Located, duration: float | None,
               line_text: str | None) -> Proposal:
    """Tagged text: ``[name]`` alone starts the signal at the next word (its typical length);
    ``[name]…[/name]`` spans the words between.  ``words`` are the words' ``[word, start, stop]``
    (else estimated).  ``line_text``: the document itself (positions are in it), else the text
    sits in a JSON string (positions are that string's)."""

    def span(offset: int) -> Span:
        if line_text is None:
            return at.span(("text",))
        line = text.count("\n", 0, offset) + 1
        return Span(at.path, line, offset - (text.rfind("\n", 0, offset) + 1) + 1)

    def fail(message: str, offset: int) -> MseError:
        return MseError([Diagnostic(CODE, message, span(offset))])

    # Words and tags in reading order.
    tokens: list[tuple[str, str, int]] = []  # (kind, text, offset): kind word | open | close
    for match in re.finditer(r"\S+", text):
        piece, base = match.group(), match.start()
        cursor = 0
        for tag in _TAG.finditer(piece):
            if tag.start() > cursor:
                tokens.append(("word", piece[cursor:tag.start()], base + cursor))
            tokens.append(("close" if tag.group(1) else "open", tag.group(2), base + tag.start()))
            cursor = tag.end()
        if cursor < len(piece):
            tokens.append(("word", piece[cursor:], base + cursor))
    stray = next((t for t in tokens if t[0] == "word" and ("[" in t[1] or "]" in t[1])), None)
    if stray is not None:
        raise fail(f"{stray[1]!r} is not a tag: tags are [name] and [/name] (a signal id or lexeme, no spaces)",
                   stray[2])
    spoken = [t for t in tokens if t[0] == "word"]
    times = _word_times(spoken, words, at, fail)
    if len(tokens) - len(spoken) > 2 * MAX_PROPOSED:
        raise fail(f"more than {MAX_PROPOSED} tags", 0)
    # Match each closing tag with the latest open tag of that name.
    opened: dict[str, list[tuple[int, int]]] = {}  # name -> [(token index, word index)]
    spans: list[tuple[str, int, int, int | None]] = []  # (name, offset, first word, last word or None)
    word_index = 0
    for kind, name, offset in tokens:
        if kind == "word":
            word_index += 1
        elif kind == "open":
            opened.setdefault(name, []).append((offset, word_index))
        else:
            if not opened.get(name):
                raise fail(f"[/{name}] closes no open [{name}]", offset)
            open_offset, first = opened[name].pop()
            spans.append((name, open_offset, first, word_index - 1 if word_index > first else None))
    for name, pending in opened.items():
        spans.extend((name, offset, first, None) for offset, first in pending)
    spans.sort(key=lambda s: s[1])
    end_of_speech = times[-1][1] if times else 0
    occurrences = []
    for name, offset, first, last in spans:
        signal = _resolve_text(model, name, fail, offset)
        start = times[first][0] if first < len(times) else end_of_speech
        if last is not None:
            stop = times[last][1]
        else:
            stop = start + (typical_length(model.signal(signal)) if signal is not None else 1000)
        occurrences.append(ProposedOccurrence(name, signal, start, stop, estimated=words is None or last is None,
                                              span=span(offset)))
    return _finish(model, occurrences, duration, at, form="text", floor=end_of_speech)


def _word_times(spoken: Sequence[tuple[str, str, int]], words: Any, at: _Located,
                fail: Any) -> list[tuple[int, int]]:
    if words is None:
        times, cursor = [], 0.0
        for _, word, _ in spoken:
            length = (len(word) + 1) / CHARS_PER_SECOND
            times.append((to_ticks(cursor), to_ticks(cursor + length)))
            cursor += length
        return times
    if not isinstance(words, list):
        raise at.fail("'words' must be a list of [word, start, stop]", ("words",))
    if len(words) != len(spoken):
        raise at.fail(f"'words' gives {len(words)} words; the text has {len(spoken)} (tags are not words)",
                      ("words",))
    times = []
    previous = 0
    for index, (entry, (_, word, _)) in enumerate(zip(words, spoken, strict=True)):
        where: Path = ("words", index)
        if (not isinstance(entry, list) or len(entry) != 3 or not isinstance(entry[0], str)
                or not all(_is_number(x) for x in entry[1:])):
            raise at.fail(f"words[{index}] must be [word, start, stop] (a string and two numbers)", where)
        if entry[0] != word:
            raise at.fail(f"words[{index}] is {entry[0]!r}; the text's word {index + 1} is {word!r}", where)
        for value in entry[1:]:
            problem = time_problem(float(value), minimum=0.0)
            if problem is not None:
                raise at.fail(f"words[{index}]: {value!r} {problem}", where)
        start, stop = to_ticks(entry[1]), to_ticks(entry[2])
        if stop <= start:
            raise at.fail(f"words[{index}] stops at {entry[2]:g} s, not after its start {entry[1]:g} s", where)
        if start < previous:
            raise at.fail(f"words[{index}] starts at {entry[1]:g} s, before the previous word stops", where)
        times.append((start, stop))
        previous = stop
    return times


# -- shared parts -------------------------------------------------------------------------------
def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _duration(obj: Mapping[str, Any], at: _Located) -> float:
    value = obj.get("duration")
    if not isinstance(value, int | float) or not _is_number(value) or not (
            MIN_DURATION_SECONDS <= float(value) <= MAX_SOLVE_SECONDS):
        raise at.fail(f"'duration' must be a number of seconds in [{MIN_DURATION_SECONDS:g}, {MAX_SOLVE_SECONDS:g}]",
                      ("duration",))
    return float(value)


def _time(entry: Mapping[str, Any], key: str, at: _Located, where: Path, *, required: bool = False) -> int | None:
    if key not in entry:
        if required:
            raise at.fail(f"{_label(where)} needs a number '{key}' (seconds)", where)
        return None
    value = entry[key]
    if not _is_number(value):
        raise at.fail(f"{_label(where)}.{key} must be a number of seconds", (*where, key))
    problem = time_problem(float(value), minimum=0.0)
    if problem is not None:
        raise at.fail(f"{_label(where)}.{key} {value!r} {problem}", (*where, key))
    return to_ticks(float(value))


def _label(where: Path) -> str:
    return f"{where[0]}[{where[1]}]" if len(where) == 2 else ".".join(str(p) for p in where)


def _resolve(model: ir.Model, name: str, by: str, at: _Located, where: Path) -> str | None:
    """The signal id ``name`` names (by id or by lexeme), None when the set does not know it."""
    if by == "signal":
        return name if name in model.signal_by_id else None
    candidates = [s.id for s in model.signals if s.lexeme == name]
    if len(candidates) > 1:
        raise at.fail(f"lexeme {name!r} is used by several signals ({', '.join(candidates)}): name one by 'signal'",
                      where)
    return candidates[0] if candidates else None


def _resolve_text(model: ir.Model, name: str, fail: Any, offset: int) -> str | None:
    """A tag names a signal by id, else by lexeme."""
    if name in model.signal_by_id:
        return name
    candidates = [s.id for s in model.signals if s.lexeme == name]
    if len(candidates) > 1:
        raise fail(f"[{name}]: lexeme {name!r} is used by several signals ({', '.join(candidates)}): "
                   "tag with a signal id", offset)
    return candidates[0] if candidates else None


def _occurrence(name: str, signal: str | None, start: int, stop: int, at: _Located,
                where: Path) -> ProposedOccurrence:
    if stop <= start:
        raise at.fail(f"{_label(where)} ({name}) stops at {stop / 1000:g} s, not after its start "
                      f"{start / 1000:g} s", where)
    return ProposedOccurrence(name, signal, start, stop, span=at.span(where))


def _finish(model: ir.Model, occurrences: list[ProposedOccurrence], duration: float | None, at: _Located, *,
            form: Form, expression: str = "", floor: int = 0) -> Proposal:
    """Check what only the whole proposal shows and fix its duration: the given one, else the
    latest stop (estimated times that run past a given duration are scaled into it)."""
    for occurrence in occurrences:
        if occurrence.stop <= occurrence.start:
            raise MseError([Diagnostic(CODE, f"{occurrence.describe()} stops before it starts", occurrence.span)])
    latest = max([floor, *(o.stop for o in occurrences)])
    if duration is None:
        ticks = latest
        if ticks < 1:
            raise at.fail("the proposal holds no occurrence and no duration (give 'duration' or --duration)")
    else:
        ticks = to_ticks(duration)
        estimated_end = max([0, *(o.stop for o in occurrences if o.estimated)])
        if estimated_end > ticks:  # an order with rough lengths that does not fit: scale it in
            occurrences = [_scaled(o, ticks, estimated_end) if o.estimated else o for o in occurrences]
    if ticks > to_ticks(MAX_SOLVE_SECONDS):
        raise at.fail(f"the proposal ends at {ticks / 1000:g} s, past the limit of {MAX_SOLVE_SECONDS:g} s")
    by_name: dict[str, list[ProposedOccurrence]] = {}
    for occurrence in occurrences:
        by_name.setdefault(occurrence.signal or occurrence.name, []).append(occurrence)
    for group in by_name.values():
        ordered = sorted(group, key=lambda o: (o.start, o.stop))
        for first, second in itertools.pairwise(ordered):
            if second.start < first.stop:
                where = first.span.render()
                raise MseError([Diagnostic(CODE, f"{second.describe()} overlaps {first.describe()} (at {where}): "
                                                 "occurrences of one signal never overlap", second.span)])
    return Proposal(ticks, tuple(occurrences), form, at.path, expression)


def _scaled(occurrence: ProposedOccurrence, duration: int, end: int) -> ProposedOccurrence:
    from dataclasses import replace

    start = occurrence.start * duration // end
    stop = max(start + 1, occurrence.stop * duration // end)
    return replace(occurrence, start=start, stop=stop)


def _with_expression(proposal: Proposal, expression: str) -> Proposal:
    from dataclasses import replace

    return replace(proposal, expression=expression)


def _replace_text(proposal: Proposal, text: str) -> Proposal:
    from dataclasses import replace

    return replace(proposal, text=text)
