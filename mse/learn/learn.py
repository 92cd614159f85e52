"""``learn``: a behaviour set and a constraint set from a corpus (docs/learn.md).

Steps: arrays over the corpus → signals (durations, profile, repetitivity) → exclusive
modalities → mined rules with evidence → redundant rules dropped (CP-SAT implication at
the corpus' typical duration) → calibrated probabilities → XML text → read back with the
project's own reader → every corpus sequence checked with the evaluator (which sequence
breaks which rule) → static and deep lint at the typical duration.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass, field, replace

from mse.diagnostics import Diagnostic, Span, argument_error
from mse.extras import require
from mse.ir import model as ir
from mse.ir.evaluate import check_schedule
from mse.ir.schedule import Occurrence, Schedule, to_seconds
from mse.learn.calibrate import Calibration
from mse.learn.corpus import Corpus
from mse.learn.mine import MiningOptions, Rule, mine
from mse.learn.signals import LearnedSignal, learn_signals
from mse.learn.stats import corpus_arrays

#: A learned offset is explained by the relations when the limit they allow is closer to it
#: than this fraction of the observed range (docs/learn.md, "Offsets").
EXPLAINED_FRACTION = 0.5


@dataclass(frozen=True)
class LearnOptions:
    name: str = "learned"
    confidence: float = 0.95
    min_support: int = 10
    significance: float = 0.001
    calibrate: bool = True
    calibration_rounds: int = 8
    calibration_samples: int = 300
    query_time: float = 1.0
    deep_lint: bool = True
    seed: int = 0


DEFAULT_OPTIONS = LearnOptions()


@dataclass(frozen=True)
class Break:
    """A corpus sequence that the learned set does not accept, and why."""

    sequence: str
    span: Span
    rule: str  # constraint id, or the kind of structural rule (duration, exclusive...)
    message: str


@dataclass(frozen=True)
class LearnResult:
    model: ir.Model
    xml: str
    corpus: Corpus
    signals: list[LearnedSignal]
    rules: list[Rule]  # kept, in file order
    redundant: list[tuple[Rule, str]]  # dropped, with the reason
    breaks: list[Break]
    diagnostics: list[Diagnostic] = field(default_factory=list)  # lint of the result, notes
    calibration: list[str] = field(default_factory=list)


def exclusive_modalities(corpus: Corpus, confidence: float) -> dict[str, str]:
    """Modalities whose annotations never overlap (in at least ``confidence`` of the
    sequences where the modality has two or more), with the evidence."""
    by_modality: dict[str, list[str]] = {}
    for info in corpus.signals.values():
        by_modality.setdefault(info.modality, []).append(info.id)
    found: dict[str, str] = {}
    for modality, members in sorted(by_modality.items()):
        tested = overlapping = 0
        for sequence in corpus.sequences:
            intervals = sorted(o for m in members for o in sequence.occurrences.get(m, ()))
            if len(intervals) < 2:
                continue
            tested += 1
            if any(intervals[i][1] > intervals[i + 1][0] for i in range(len(intervals) - 1)):
                overlapping += 1
        if tested and (tested - overlapping) >= confidence * tested - 1e-9:
            found[modality] = (f"exclusive: no overlap in {tested - overlapping} of the {tested} sequences "
                               f"with two or more {modality} annotations")
    return found


def learn_corpus(corpus: Corpus, options: LearnOptions = DEFAULT_OPTIONS) -> LearnResult:
    if not 0 < options.confidence <= 1:
        raise argument_error("--confidence must be in (0, 1]")
    with require("learn"):  # the binomial tail of the mined rules (mine.py): said before any work, not midway
        import scipy.stats  # noqa: F401
    arrays = corpus_arrays(corpus)
    learned = learn_signals(corpus, arrays, options.confidence)
    exclusive = exclusive_modalities(corpus, options.confidence)
    modalities = tuple(ir.Modality(name, True) for name in exclusive)
    base = ir.Model(options.name, tuple(s.signal for s in learned), (), modalities)
    candidates = mine(corpus, arrays, MiningOptions(options.confidence, options.min_support, options.significance))
    kept, redundant = select_rules(base, candidates, corpus.typical_duration, options)
    model = replace(base, constraints=tuple(ir.Constraint(r.id, r.expr) for r in kept))
    calibration: list[str] = []
    if options.calibrate and options.calibration_rounds > 0:
        model, calibration, released = _calibrated(model, corpus, options, late=(), release=True)
        if released:
            reasons = dict(released)
            redundant += [(r, reasons[r.id]) for r in kept if r.id in reasons]
            kept = [r for r in kept if r.id not in reasons]
    late: set[str] = set()
    for attempt in range(2):
        xml = _xml(model, corpus, learned, kept, exclusive, options)
        final = _read_back(xml, options.name)
        diagnostics = _lint(final, corpus, options)
        # W406: the constraints never let the signal start in the first second, so a
        # probability_start above 0 is a promise the sampler cannot keep: start at 0, and
        # calibrate again with that profile.  A once-only signal above level 0.5 keeps its
        # profile (a line from 0 cannot reach its rate), and the warning.
        early = {s.id: (s.probability_start + s.probability_end) / 2 for s in model.signals for d in diagnostics
                 if d.code == "W406" and f"signal {s.id!r} has probability_start" in d.message}
        fixable = {name for name, level in early.items() if level <= 0.5 or model.signal(name).repetitivity}
        if early.keys() - fixable:
            calibration.append("probability_start kept above 0 despite W406 (a profile from 0 cannot reach "
                               f"their rate): {', '.join(sorted(early.keys() - fixable))}")
        if not fixable or attempt:
            break
        late |= fixable
        calibration.append(f"probability_start set to 0 (W406): {', '.join(sorted(fixable))}")
        if options.calibrate and options.calibration_rounds > 0:
            model, notes, _ = _calibrated(model, corpus, options, late=late)
            calibration.extend(notes)
        else:
            from mse.learn.calibrate import with_late

            model = with_late(model, late)
    breaks = corpus_breaks(final, corpus)
    return LearnResult(final, xml, corpus, learned, kept, redundant, breaks, diagnostics, calibration)


def _calibrated(model: ir.Model, corpus: Corpus, options: LearnOptions, late: Collection[str],
                release: bool = False) -> tuple[ir.Model, list[str], list[tuple[str, str]]]:
    """Calibrated probabilities; with ``release``, then the rules that keep a signal from the
    corpus' rate whatever its probabilities are released and the rest calibrated again, kept
    only when that calibration ends closer to the corpus than the first (a release moves
    other signals too, and a counted signal's presence)."""
    from mse.learn.calibrate import calibrate, release_rules

    def run(start: ir.Model) -> Calibration:
        return calibrate(start, corpus, rounds=options.calibration_rounds, samples=options.calibration_samples,
                         seed=options.seed, late=late)

    first = run(model)
    if not release:
        return first.model, first.notes, []
    loosened, released = release_rules(first, corpus, samples=options.calibration_samples, seed=options.seed)
    if not released:
        return first.model, first.notes, []
    again = run(loosened)
    notes = [*first.notes, *(f"rule {rule} {why}" for rule, why in released), *again.notes]
    if again.score >= first.score:
        return first.model, [*notes, f"released rules kept: calibrated without them the set is no closer to the "
                                     f"corpus (distance {again.score:.3f} against {first.score:.3f})"], []
    return again.model, notes, released


def select_rules(base: ir.Model, candidates: list[Rule], duration: int,
                 options: LearnOptions) -> tuple[list[Rule], list[tuple[Rule, str]]]:
    """Drop the offsets the other rules explain, then every rule the others imply."""
    if not candidates:
        return [], []
    from mse.learn.implication import ImplicationChecker

    model = replace(base, constraints=tuple(ir.Constraint(r.id, r.expr) for r in candidates))
    checker = ImplicationChecker(model, duration=duration, query_time=options.query_time)
    dropped: list[tuple[Rule, str]] = []
    structure = [r.id for r in candidates if r.bound is None]
    alive = {r.id for r in candidates}
    threshold = math.log(1 / options.significance)
    # Most significant offsets first: each one kept joins what explains the next ones.
    bounds = sorted((r for r in candidates if r.bound is not None), key=lambda r: (r.p_value, -r.support, r.id))
    for rule in bounds:
        info = rule.bound
        assert info is not None
        margin = max(1.0, info.spacing * threshold, EXPLAINED_FRACTION * info.spread)
        # Not explained iff the other rules allow y - x beyond the offset by the margin.
        beyond = info.offset - margin if info.side == "lower" else info.offset + margin
        answer = checker.reaches((info.a, info.x_edge), (info.b, info.y_edge), structure, beyond,
                                 largest=info.side == "upper")
        if answer == "infeasible":
            alive.discard(rule.id)
            dropped.append((rule, f"explained by the other rules: they never let it go {margin / 1000:g} s "
                                  f"beyond the {info.observed / 1000:g} s the corpus reached"))
        else:
            structure.append(rule.id)
    order = sorted((r for r in candidates if r.id in alive), key=lambda r: (r.rank, r.support, -r.p_value, r.id))
    for rule in order:
        if checker.implied(rule.id, alive - {rule.id}) == "yes":
            alive.discard(rule.id)
            dropped.append((rule, f"implied by the other rules at {to_seconds(duration):g} s"))
    kept = sorted((r for r in candidates if r.id in alive), key=lambda r: (-r.rank, r.id))
    return kept, dropped


def _xml(model: ir.Model, corpus: Corpus, learned: list[LearnedSignal], kept: list[Rule],
         exclusive: dict[str, str], options: LearnOptions) -> str:
    from mse.learn.write import behaviour_set_xml

    n = len(corpus.sequences)
    description = (
        f"Learned by mse learn from {n} sequences (typical duration {to_seconds(corpus.typical_duration):g} s): "
        f"rules holding in at least {options.confidence:g} of the sequences where they are tested, "
        f"support at least {options.min_support}, significance {options.significance:g}; redundant rules dropped."
    )
    return behaviour_set_xml(
        model,
        description=description,
        signal_notes={s.signal.id: s.evidence for s in learned},
        constraint_notes={r.id: r.evidence() for r in kept},
        modality_notes=exclusive,
    )


def _read_back(xml: str, name: str) -> ir.Model:
    """The written text through the project's reader: what a user loads is what is checked."""
    from mse.ir.build import build_model
    from mse.syntax.reader import read_document

    path = f"<learned {name}>"
    document, diagnostics = read_document(path, xml.encode("utf-8"))
    if document is None:
        raise RuntimeError("learned set not readable (a bug): " + "; ".join(d.render() for d in diagnostics))
    model, problems = build_model(document)
    errors = [d for d in [*diagnostics, *problems] if d.is_error]
    if model is None or errors:
        raise RuntimeError("learned set not valid (a bug): " + "; ".join(d.render() for d in errors))
    return model


def sequence_schedule(sequence_duration: int, occurrences: dict[str, tuple[tuple[int, int], ...]]) -> Schedule:
    return Schedule.of(sequence_duration, (Occurrence(start, stop, signal)
                                           for signal, items in occurrences.items() for start, stop in items))


def corpus_breaks(model: ir.Model, corpus: Corpus) -> list[Break]:
    """Every (sequence, rule) the evaluator rejects."""
    found: list[Break] = []
    for sequence in corpus.sequences:
        schedule = sequence_schedule(sequence.duration, dict(sequence.occurrences))
        for violation in check_schedule(model, schedule):
            rule = violation.constraint or violation.kind
            found.append(Break(sequence.name, sequence.span, rule, violation.message))
    return found


def _lint(model: ir.Model, corpus: Corpus, options: LearnOptions) -> list[Diagnostic]:
    from mse.ir.lint import lint_model

    found = list(lint_model(model))
    seconds = to_seconds(corpus.typical_duration)
    if options.deep_lint:
        from mse.solve.cpsat.deep_lint import deep_lint

        found.extend(deep_lint(model, seconds))
    from mse.solve.protocol import NoSolution, SolveRequest, get_solver

    try:
        get_solver("greedy").solve(model, SolveRequest(duration=seconds, seed=options.seed))
    except NoSolution as error:
        found.append(Diagnostic("W401", f"the default sampler found no timeline of {seconds:g} s: "
                                + "; ".join(d.message for d in error.diagnostics), Span(model.path)))
    return found
