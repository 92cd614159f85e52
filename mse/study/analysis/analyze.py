"""From answers to the study's numbers: hit rates per emotion and condition, confusion matrices,
agreement, believability preferences (docs/study-analysis.md)."""

from __future__ import annotations

import math
from collections import Counter, defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from mse.diagnostics import Diagnostic, MseError, argument_error
from mse.study.analysis import statistics
from mse.study.analysis.results import MSE_CONDITION, NAME, Answer


@dataclass(frozen=True, slots=True)
class Options:
    """How to analyse: the labels offered to participants (None: the ones seen), the confidence
    interval, the significance level, the correction for multiple comparisons, the preference test."""

    labels: tuple[str, ...] | None = None
    ci: str = "wilson"
    level: float = 0.95
    alpha: float = 0.05
    correction: str = "holm"
    preference_test: str = "binomial"

    def check(self) -> None:
        problems = []
        if self.ci not in statistics.CI_METHODS:
            problems.append(f"--ci must be one of {', '.join(statistics.CI_METHODS)}")
        if not 0 < self.level < 1:
            problems.append("--level must be between 0 and 1 (e.g. 0.95)")
        if not 0 < self.alpha < 1:
            problems.append("--alpha must be between 0 and 1 (e.g. 0.05)")
        if self.correction not in statistics.CORRECTIONS:
            problems.append(f"--correction must be one of {', '.join(statistics.CORRECTIONS)}")
        if self.preference_test not in statistics.PREFERENCE_TESTS:
            problems.append(f"--preference-test must be one of {', '.join(statistics.PREFERENCE_TESTS)}")
        if self.labels is not None:
            if len(self.labels) < 2:
                problems.append("--labels must name at least two labels")
            bad = [label for label in self.labels if not NAME.match(label)]
            if bad:
                problems.append(f"--labels: {bad[0][:60]!r} is not a label name (letters, digits, '_', '.', '-')")
            if len(set(self.labels)) != len(self.labels):
                problems.append("--labels names a label twice")
        if problems:
            raise argument_error(*problems)


@dataclass(frozen=True, slots=True)
class LabelResult:
    """Recognition of one emotion's stimuli in one condition."""

    emotion: str
    condition: str
    answers: int
    hits: int
    hit_rate: float
    ci: tuple[float, float]
    #: One-sided exact binomial test of the hits against chance (1 / number of labels offered).
    p: float
    p_adjusted: float
    significant: bool
    #: The unbiased hit rate of the paper's equation (1) (statistics.unbiased_kappa).
    kappa: float
    #: The other label chosen most often (None: no other), how often, and the test of the hits
    #: against it (statistics.hits_against_confusion), adjusted like the tests against chance.
    confusion: str | None
    confused: int
    confusion_p: float
    confusion_p_adjusted: float


@dataclass(frozen=True, slots=True)
class Confusion:
    """Answers of one condition: one row per presented emotion, one column per label offered."""

    condition: str
    emotions: tuple[str, ...]
    labels: tuple[str, ...]
    counts: tuple[tuple[int, ...], ...]


@dataclass(frozen=True, slots=True)
class Agreement:
    """Fleiss' κ of the participants' labels in one condition (None, with the reason, when undefined)."""

    condition: str
    kappa: float | None
    subjects: int
    ratings: int
    #: What a subject is: each stimulus, or each emotion when the results name no stimuli.
    subject: str
    reason: str = ""


@dataclass(frozen=True, slots=True)
class Preference:
    """Believability choices between an emotion's MSE stimulus and another condition's."""

    emotion: str
    against: str
    answers: int
    chosen: int
    share: float
    ci: tuple[float, float]
    p: float
    p_adjusted: float
    significant: bool
    #: Fraction of the choices that went to the stimulus shown on the left (a position bias check).
    left_share: float


@dataclass(frozen=True, slots=True)
class Analysis:
    options: Options
    files: tuple[str, ...]
    answers: int
    participants: int
    labels: tuple[str, ...]
    #: How the labels offered were determined (the option, or the names seen in the answers).
    labels_source: str
    #: 1 / the number of labels offered (None: no label answers).
    chance: float | None
    results: tuple[LabelResult, ...]
    confusions: tuple[Confusion, ...]
    agreements: tuple[Agreement, ...]
    preferences: tuple[Preference, ...]


def analyze(answers: Sequence[Answer], options: Options = Options(), files: Sequence[str] = ()) -> Analysis:
    """The study's numbers from its answers (MseError E171 for a label outside ``options.labels``)."""
    options.check()
    labelled = [a for a in answers if a.task == "label"]
    paired = [a for a in answers if a.task == "pair"]
    labels, source = _labels(labelled, options)
    chance = 1 / len(labels) if labels else None
    confusions = tuple(_confusion(condition, labelled, labels) for condition in _ordered(a.condition for a in labelled))
    results = _label_results(confusions, len(labels), options)
    agreements = tuple(_agreement(c.condition, [a for a in labelled if a.condition == c.condition], labels)
                       for c in confusions)
    return Analysis(
        options=options,
        files=tuple(files),
        answers=len(answers),
        participants=len({a.participant for a in answers}),
        labels=labels,
        labels_source=source,
        chance=chance,
        results=results,
        confusions=confusions,
        agreements=agreements,
        preferences=_preferences(paired, options),
    )


def _ordered(names: Iterable[str]) -> list[str]:
    return sorted(set(names))


def _labels(labelled: Sequence[Answer], options: Options) -> tuple[tuple[str, ...], str]:
    seen = _ordered([a.emotion for a in labelled] + [a.response for a in labelled])
    if options.labels is None:
        if not labelled:
            return (), "no label answers"
        if len(seen) < 2:
            raise argument_error("the answers use fewer than two labels: name the labels offered with --labels")
        return tuple(seen), "the intended emotions and the responses seen in the answers"
    offered = set(options.labels)
    stray = [Diagnostic("E171", f"{what} {value!r} is not one of --labels", a.span)
             for a in labelled for what, value in (("emotion", a.emotion), ("response", a.response))
             if value not in offered]
    if stray:
        raise MseError(stray[:20])
    return tuple(options.labels), "--labels"


def _confusion(condition: str, labelled: Sequence[Answer], labels: tuple[str, ...]) -> Confusion:
    mine = [a for a in labelled if a.condition == condition]
    emotions = tuple(_ordered(a.emotion for a in mine))
    counts = Counter((a.emotion, a.response) for a in mine)
    # the presented emotions' own labels first, in the rows' order, then the other labels offered
    columns = tuple([e for e in emotions if e in labels] + [label for label in labels if label not in emotions])
    return Confusion(condition, emotions, columns,
                     tuple(tuple(counts[(emotion, label)] for label in columns) for emotion in emotions))


def _label_results(confusions: Sequence[Confusion], labels: int, options: Options) -> tuple[LabelResult, ...]:
    rows = []
    for confusion in confusions:
        for index, emotion in enumerate(confusion.emotions):
            counts = confusion.counts[index]
            column = confusion.labels.index(emotion) if emotion in confusion.labels else None
            hits = counts[column] if column is not None else 0
            others = [(count, label) for label, count in zip(confusion.labels, counts, strict=True)
                      if label != emotion and count > 0]
            # the most chosen other label; a tie goes to the first in the matrix' column order
            count, label = max(others, key=lambda item: item[0]) if others else (0, None)
            rows.append((emotion, confusion.condition, sum(counts), hits,
                         statistics.unbiased_kappa(confusion.counts, index, column, labels), label, count))
    p_values = [statistics.above_chance(row[3], row[2], 1 / labels) for row in rows]
    corrected = statistics.adjusted(p_values, options.correction)
    confusion_p = [statistics.hits_against_confusion(row[3], row[6]) for row in rows]
    confusion_corrected = statistics.adjusted(confusion_p, options.correction)
    return tuple(
        LabelResult(emotion, condition, answers, hits, hits / answers,
                    statistics.proportion_interval(hits, answers, options.level, options.ci),
                    p, p_adjusted, p_adjusted < options.alpha, kappa, label, count, c_p, c_adjusted)
        for (emotion, condition, answers, hits, kappa, label, count), p, p_adjusted, c_p, c_adjusted
        in zip(rows, p_values, corrected, confusion_p, confusion_corrected, strict=True)
    )


def _agreement(condition: str, mine: Sequence[Answer], labels: tuple[str, ...]) -> Agreement:
    by_stimulus = all(a.stimulus for a in mine)
    subject = "stimulus" if by_stimulus else "emotion"
    table: dict[str, Counter[str]] = defaultdict(Counter)
    for answer in mine:
        table[answer.stimulus if by_stimulus else answer.emotion][answer.response] += 1
    sizes = {sum(counts.values()) for counts in table.values()}
    ratings = min(sizes)
    if len(table) < 2:
        return Agreement(condition, None, len(table), ratings, subject, f"one {subject} only")
    if len(sizes) > 1:
        return Agreement(condition, None, len(table), ratings, subject,
                         f"each {subject} must have the same number of answers (here {min(sizes)} to {max(sizes)})")
    if ratings < 2:
        return Agreement(condition, None, len(table), ratings, subject, f"one answer per {subject}")
    kappa = statistics.fleiss_kappa([[counts[label] for label in labels] for counts in table.values()])
    if not math.isfinite(kappa):
        return Agreement(condition, None, len(table), ratings, subject, "every answer gave the same label")
    return Agreement(condition, kappa, len(table), ratings, subject)


def _preferences(paired: Sequence[Answer], options: Options) -> tuple[Preference, ...]:
    groups: dict[str, list[Answer]] = defaultdict(list)
    for answer in paired:
        groups[answer.emotion].append(answer)
    rows = []
    for emotion in sorted(groups):
        mine = groups[emotion]
        others = _ordered(c for a in mine for c in a.conditions if c != MSE_CONDITION)
        if len(others) > 1:
            second = next(a for a in mine if others[1] in a.conditions)
            raise MseError([Diagnostic(
                "E171", f"{emotion}'s believability pairs compare {MSE_CONDITION!r} with both {others[0]!r} and "
                f"{others[1]!r}: analyse each comparison's results separately", second.span)])
        chosen = sum(a.response == MSE_CONDITION for a in mine)
        left = sum(a.response == a.conditions[0] for a in mine)
        rows.append((emotion, others[0], len(mine), chosen, left))
    p_values = [statistics.preference_p(chosen, n, options.preference_test) for _, _, n, chosen, _ in rows]
    corrected = statistics.adjusted(p_values, options.correction)
    return tuple(
        Preference(emotion, against, n, chosen, chosen / n,
                   statistics.proportion_interval(chosen, n, options.level, options.ci),
                   p, p_adjusted, p_adjusted < options.alpha, left / n)
        for (emotion, against, n, chosen, left), p, p_adjusted in zip(rows, p_values, corrected, strict=True)
    )
