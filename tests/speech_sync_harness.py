"""Generated dialogues for the speech-sync checks (tests/test_speech_bml.py, bench/evaluation/speech_sync.py):
scripts whose utterances start where an emotion changes and whose announced ends fall on word
boundaries, as a scripted agent's do, planned by ``mse live``'s planner, exported in every BML
profile, then read back from what Greta's and AsapRealizer's own parsers report."""

from __future__ import annotations

import random
import re
from dataclasses import dataclass, replace
from pathlib import Path

from mse.dialogue import plan_script
from mse.dialogue.script import EmotionEvent, EndEvent, Event, SayEvent, Word
from mse.export import ExportOptions, render
from mse.export.behaviours import plan_behaviours
from mse.export.speech_bml import SYNC_TOLERANCE, utterances_from_json
from mse.resources import bundled_names
from mse.timeline import Timeline

VOCABULARY = "I you we can't believe did that really oh well so sorry it was fine never again maybe".split()  # noqa: SIM905
#: profile -> (format, options); the BML 1.0 ones go to AsapRealizer's parser, the others to Greta's.
PROFILES = {
    "generic": ("bml", ExportOptions()),
    "asap": ("bml", ExportOptions(realizer="asap")),
    "greta-bml": ("greta-bml", ExportOptions()),
    "greta-in-bml": ("bml", ExportOptions(realizer="greta")),
}
ASAP_PROFILES = ("generic", "asap")


def _ms(value: float) -> float:
    return round(value, 3)


def random_script(rng: random.Random, episodes: int = 4) -> list[Event]:
    """Emotion changes every 2-6 s; an utterance starting at most changes, words of 0.1-0.5 s with
    pauses; most episodes announced, ending on a word's stop when one is spoken."""
    names = bundled_names()
    events: list[Event] = []
    t = 0.0
    for _ in range(episodes):
        length = _ms(rng.uniform(2.0, 6.0))
        words: list[Word] = []
        if rng.random() < 0.8:
            at = t
            for _ in range(rng.randint(2, 20)):
                stop = _ms(at + rng.uniform(0.1, 0.5))
                if stop > t + length - 0.1:
                    break
                words.append(Word(rng.choice(VOCABULARY), at, stop))
                at = _ms(stop + (rng.uniform(0.05, 0.3) if rng.random() < 0.3 else 0.0))
        until = None
        if rng.random() < 0.75:
            on_word = words and words[-1].stop >= t + 2.0 and rng.random() < 0.5
            until = words[-1].stop if on_word else _ms(t + length)
        events.append(EmotionEvent(t, rng.choice(names), _ms(rng.uniform(0.3, 1.0)), until))
        if words:
            stress = tuple(sorted({rng.choice(words).text}))
            events.append(SayEvent(t, " ".join(w.text for w in words), tuple(words), stress))
        t = until if until is not None else _ms(t + length)
    events.append(EndEvent(t))
    return events


#: An occurrence boundary this close to a word boundary is moved onto it (see :func:`anchored`).
SNAP = 0.25


def anchored(timeline: Timeline) -> Timeline:
    """The timeline with every occurrence start or stop within :data:`SNAP` of a word boundary
    moved onto it: what an anchor to a word ("the nod starts on a stressed word") makes the
    planner do.  This checks the writer and the realizers, not the planner."""
    boundaries = sorted(
        {t for u in utterances_from_json(timeline.utterances) for w in u.words for t in (w.start, w.stop)}
    )

    def snap(time: float) -> float:
        near = min(boundaries, key=lambda b: abs(b - time), default=None)
        return near if near is not None and abs(near - time) <= SNAP else time

    signals = []
    for signal in timeline.signals:
        start, stop = snap(signal.start), snap(signal.stop)
        if stop - start < 0.1:
            start, stop = signal.start, signal.stop
        signals.append(replace(signal, start=start, stop=stop))
    return timeline.with_signals(signals)


def generated_dialogues(count: int, seed: int = 0) -> list[Timeline]:
    rng = random.Random(seed)
    return [anchored(plan_script(random_script(rng), seed=seed * 1000 + n)) for n in range(count)]


@dataclass
class Written:
    """One exported file: its profile and the times mse planned for each written id."""

    path: Path
    profile: str
    timeline: Timeline
    text: str

    def planned(self) -> dict[str, tuple[float, float]]:
        return {b.id: (b.signal.start, b.signal.stop) for b in plan_behaviours(self.timeline)}

    def references(self) -> list[tuple[str, str, str]]:
        """(element id, start|end, speechN:syncM) written in the file."""
        found = []
        for match in re.finditer(r'<(?!sync|tm|pitchaccent)\S+ id="([^"]+)"([^>]*)>', self.text):
            for key, value in re.findall(r' (start|end)="([^"]+)"', match.group(2)):
                if ":" in value:
                    found.append((match.group(1), key, value))
        return found


def write_all(timelines: list[Timeline], folder: Path) -> list[Written]:
    written = []
    for index, timeline in enumerate(timelines):
        for profile, (fmt, options) in PROFILES.items():
            text = render(timeline, fmt, options)
            path = folder / profile / f"dialogue-{index:03d}.xml"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
            written.append(Written(path, profile, timeline, text))
    return written


_SYNC_TAG = re.compile(r'<sync id="([^"]+)"[^>]*/>')


def asap_sync_times(content: str, timeline: Timeline, speech_id: str) -> dict[str, float]:
    """The time of each sync point of a speech as AsapRealizer's parser holds it (its ``content``):
    a sync followed by a word is that word's start, else the stop of the word before it; the
    words are the utterance's, counted in the parsed text."""
    number = int(speech_id.removeprefix("speech").rstrip("_"))
    words = utterances_from_json(timeline.utterances)[number - 1].words
    times: dict[str, float] = {}
    position, spoken = 0, 0
    for match in _SYNC_TAG.finditer(content):
        spoken += len(content[position : match.start()].split())
        rest = content[match.end() :]
        follows_word = bool(rest) and not rest[0].isspace() and not rest.startswith("<") and spoken < len(words)
        times[match.group(1)] = words[spoken].start if follows_word else words[spoken - 1].stop
        position = match.end()
    return times


TOLERANCE = SYNC_TOLERANCE


@dataclass
class Verdict:
    """What the parsers made of the written dialogues."""

    files: int = 0
    rejected: list[str] | None = None
    references: int = 0  # sync references written
    resolved: int = 0  # ... that the parser resolved to the time mse planned
    problems: list[str] | None = None

    def __post_init__(self) -> None:
        self.rejected = self.rejected or []
        self.problems = self.problems or []


_CONTENT = re.compile(r"content='(.*)' sync start=")


def verify(written: list[Written], shared: Path, folder: Path) -> Verdict:
    """Run AsapRealizer's and Greta's parsers over ``written`` and check every behaviour's times,
    sync references resolved through the parser's own reading of the speech (ASAP: the syncs in
    the text it parsed; Greta: its Temporizer's times, from its time markers)."""
    from realizer_harness import greta_run_folder, run_asap, run_greta

    verdict = Verdict()
    asap_files = [w for w in written if w.profile in ASAP_PROFILES]
    greta_files = [w for w in written if w.profile not in ASAP_PROFILES]
    asap = run_asap(shared, [w.path for w in asap_files])
    greta = run_greta(
        shared, greta_run_folder(shared, shared / "greta", folder / "greta-run"), [w.path for w in greta_files]
    )
    assert verdict.rejected is not None and verdict.problems is not None
    for w in asap_files:
        verdict.files += 1
        parsed = asap[w.path]
        if parsed.rejected:
            verdict.rejected.append(f"{w.path}: {parsed.rejected}")
            continue
        speech = {}
        for bid, behaviour in parsed.behaviours.items():
            content = _CONTENT.search(behaviour.line)
            if behaviour.kind == "SpeechBehaviour" and content:
                speech[bid] = asap_sync_times(content.group(1), w.timeline, bid)
        planned = w.planned()
        for bid, key, reference in w.references():
            verdict.references += 1
            raw = re.search(rf" id={re.escape(bid)} .*sync {key}=\[([^\]]*)\]", parsed.behaviours[bid].line)
            speech_id, _, sync = (raw.group(1) if raw else "").partition(":")
            time = speech.get(speech_id, {}).get(sync)
            want = planned[re.sub(r"_au\d+$", "", bid)][0 if key == "start" else 1]
            if raw and raw.group(1) == reference and time is not None and abs(time - want) <= TOLERANCE + 1e-9:
                verdict.resolved += 1
            else:
                verdict.problems.append(
                    f"{w.path.name} {bid}.{key}={reference}: ASAP {raw and raw.group(1)} -> {time}, planned {want}"
                )
    for w in greta_files:
        verdict.files += 1
        parsed = greta[w.path]
        if not parsed.realized or parsed.exception:
            verdict.rejected.append(f"{w.path}: {parsed.exception or 'not realized'}")
            continue
        planned = w.planned()
        synced = {(bid, key) for bid, key, _ in w.references()}
        verdict.references += len(synced)
        for bid, (start, end) in parsed.timed.items():
            if bid not in planned:
                continue
            for key, got, want in (("start", start, planned[bid][0]), ("end", end, planned[bid][1])):
                ok = got is not None and abs(got - want) <= TOLERANCE + 1e-9
                if (bid, key) in synced and ok:
                    verdict.resolved += 1
                if not ok:
                    verdict.problems.append(f"{w.path.name} {bid}.{key}: Greta {got}, planned {want}")
    return verdict
