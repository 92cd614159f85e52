"""What a study shows and to whom: the stimuli (emotion × condition × k), the commands
that make each one, and every participant's counterbalanced order of trials.

Conditions (docs/study.md):

* ``mse``: a timeline sampled with the constraints (``mse sample``), as a video;
* ``control``: the same set and seed sampled without the constraints (``--mode
  constraint-less``, the paper's §5.3 control), as a video;
* ``image``: one frame of the ``mse`` timeline at its apex, shown as long as a video;
* ``face``: the ``mse`` timeline with only its face, gaze and head signals, as a video.

Stimulus ``k`` of an emotion uses one seed in every condition, so that its control, its
image and its face-only version are made from the same draw as its MSE video.
"""

from __future__ import annotations

import itertools
import random
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from mse.study.analysis.results import OPTIONAL, REQUIRED
from mse.study.latin import balanced_latin_square

#: Every condition, in the order the manifest lists them.
CONDITIONS: tuple[str, ...] = ("mse", "control", "image", "face")
#: The label a participant chooses when none of the study's emotions fits.
OTHER = "other"
#: Seeds a stimulus tries before it settles for a draw that shows no face signal.
SEED_TRIES = 50
#: Signals a face-only stimulus keeps: what the face picture itself shows.
FACE_MODALITIES: tuple[str, ...] = ("face", "gaze", "head")
#: The results CSV (one row per answer), shared with ``mse study analyze``.
RESULT_COLUMNS: tuple[str, ...] = (*REQUIRED, *OPTIONAL)


@dataclass(frozen=True)
class Emotion:
    """One emotion of the study: its name (the behaviour set's), how the ``mse`` commands
    name its set (a bundled name or an absolute path) and the set's SHA-256."""

    name: str
    source: str
    sha256: str


@dataclass(frozen=True)
class Settings:
    """The knobs of ``mse study make``."""

    duration: float = 4.0
    seed: int = 0
    participants: int = 8
    per_condition: int = 1
    face_only: bool = False
    size: tuple[int, int] = (640, 720)
    fps: float = 25.0


@dataclass(frozen=True)
class Stimulus:
    """One stimulus: a video (or an image at ``apex``) in ``file``, made from ``timeline``."""

    id: str
    emotion: str
    condition: str
    index: int
    seed: int
    file: str
    timeline: str
    #: the ``mse`` stimulus a face-only one is cut from (None otherwise)
    derived_from: str | None = None
    apex: float | None = None
    commands: tuple[tuple[str, ...], ...] = field(default_factory=tuple)

    @property
    def kind(self) -> str:
        return "image" if self.condition == "image" else "video"


@dataclass(frozen=True)
class Pair:
    """A believability trial: two stimuli of one emotion side by side."""

    emotion: str
    left: str
    right: str


@dataclass(frozen=True)
class Participant:
    id: str
    labels: tuple[str, ...]
    pairs: tuple[Pair, ...]


def conditions(settings: Settings) -> tuple[str, ...]:
    return tuple(c for c in CONDITIONS if c != "face" or settings.face_only)


def stimulus_ids(count: int, seed: int) -> list[str]:
    """Opaque ids (``s01`` …) in an order drawn from the seed, so that neither a file name
    nor its place in the folder tells the emotion or the condition."""
    width = max(2, len(str(count)))
    numbers = list(range(1, count + 1))
    random.Random(seed).shuffle(numbers)
    return [f"s{number:0{width}d}" for number in numbers]


def sample_command(emotion: Emotion, stimulus_seed: int, timeline: str, settings: Settings, *,
                   control: bool) -> tuple[str, ...]:
    command = ["mse", "sample", emotion.source, "-d", f"{settings.duration:g}", "--seed", str(stimulus_seed)]
    if control:
        command += ["--mode", "constraint-less"]
    return (*command, "-o", timeline, "-q")


def render_command(timeline: str, output: str, settings: Settings, at: float | None = None) -> tuple[str, ...]:
    width, height = settings.size
    command = ["mse", "render", timeline, "-o", output, "--size", f"{width}x{height}", "--fps", f"{settings.fps:g}",
               "--no-strip", "--no-title"]
    if at is not None:
        command += ["--at", f"{at:g}"]
    return (*command, "-q")


def candidate_seeds(emotions: Sequence[Emotion], settings: Settings, e: int, k: int) -> Iterator[int]:
    """The seeds stimulus ``k`` of emotion ``e`` tries in turn: the study's seed plus its rank,
    then steps of the number of stimuli per condition, so that no two stimuli share a seed."""
    step = len(emotions) * settings.per_condition
    base = settings.seed + e * settings.per_condition + k
    return (base + j * step for j in range(SEED_TRIES))


def plan_stimuli(emotions: Sequence[Emotion], settings: Settings,
                 seeds: Mapping[tuple[int, int], int] | None = None) -> list[Stimulus]:
    """Every stimulus (apex times and face-only timelines are filled in when they are made);
    ``seeds`` gives the seed of stimulus ``k`` of emotion ``e`` (default: the first candidate)."""
    chosen = conditions(settings)
    count = len(emotions) * settings.per_condition * len(chosen)
    ids = iter(stimulus_ids(count, settings.seed))
    stimuli = []
    for e, emotion in enumerate(emotions):
        for k in range(settings.per_condition):
            seed = seeds[e, k] if seeds is not None else next(candidate_seeds(emotions, settings, e, k))
            mse_id = ""
            for condition in chosen:
                sid = next(ids)
                timeline = f"timelines/{sid}.json"
                suffix = ".png" if condition == "image" else ".webm"
                file = f"stimuli/{sid}{suffix}"
                derived = None
                if condition == "mse":
                    mse_id = sid
                if condition == "face":
                    derived = mse_id
                    commands: tuple[tuple[str, ...], ...] = ()
                else:
                    sample = sample_command(emotion, seed, timeline, settings, control=condition == "control")
                    commands = (sample,) if condition == "image" else (sample, render_command(timeline, file, settings))
                stimuli.append(Stimulus(sid, emotion.name, condition, k + 1, seed, file, timeline, derived,
                                        commands=commands))
    return stimuli


def plan_participants(stimuli: Sequence[Stimulus], count: int) -> list[Participant]:
    """Participant ``p``: row ``p`` of a balanced Latin square over the label trials and
    one over the pairs; in pair ``j`` the MSE video is on the left when ``p + j`` is even
    (each side equally often for every pair, and within a participant's session)."""
    label_ids = [s.id for s in stimuli]
    mse_ids = {(s.emotion, s.index): s.id for s in stimuli if s.condition == "mse"}
    control_ids = {(s.emotion, s.index): s.id for s in stimuli if s.condition == "control"}
    pairs = [(key[0], mse_ids[key], control_ids[key]) for key in mse_ids]
    label_rows = balanced_latin_square(len(label_ids))
    pair_rows = balanced_latin_square(len(pairs)) if pairs else [[]]
    width = max(2, len(str(count)))
    participants = []
    for p in range(count):
        labels = tuple(label_ids[i] for i in label_rows[p % len(label_rows)])
        shown = []
        for j in pair_rows[p % len(pair_rows)]:
            emotion, mse_id, control_id = pairs[j]
            left, right = (mse_id, control_id) if (p + j) % 2 == 0 else (control_id, mse_id)
            shown.append(Pair(emotion, left, right))
        participants.append(Participant(f"p{p + 1:0{width}d}", labels, tuple(shown)))
    return participants


def apex(timeline: dict[str, Any]) -> float:
    """The apex of a timeline: the middle of the longest stretch in which the most face
    signals (then the most signals) are shown at once (the start when it has no signal).  The
    face first: a still picture carries the expression by the face, not by a pose alone."""
    signals = timeline.get("signals") or []
    edges = sorted({0.0, float(timeline["duration"])} | {float(s[k]) for s in signals for k in ("start", "stop")})
    best: tuple[int, int, float, float] = (-1, -1, 0.0, 0.0)
    for start, stop in itertools.pairwise(edges):
        if stop <= start:
            continue
        middle = (start + stop) / 2
        active = [s for s in signals if float(s["start"]) <= middle < float(s["stop"])]
        faces = sum(1 for s in active if s.get("modality") == "face")
        if (faces, len(active), stop - start) > best[:3]:
            best = (faces, len(active), stop - start, middle)
    return round(best[3], 3)


def face_only(timeline: dict[str, Any]) -> dict[str, Any]:
    """The timeline with only its face, gaze and head signals."""
    signals = [s for s in timeline.get("signals") or [] if s.get("modality") in FACE_MODALITIES]
    return {**timeline, "signals": signals}
