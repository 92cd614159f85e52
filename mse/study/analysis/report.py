"""The analysis as JSON (machine-readable) and as a Markdown report with its pictures."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mse.study.analysis.analyze import Analysis, LabelResult
from mse.study.analysis.statistics import CORRECTIONS

_DIGITS = 6
_TEST_NAMES = {"binomial": "exact binomial test (two-sided) against 0.5",
               "chi2": "χ² goodness-of-fit test against an even choice (the paper's test)"}
_CI_NAMES = {"wilson": "Wilson score", "clopper-pearson": "Clopper–Pearson (exact)"}


def _number(value: float) -> float:
    return round(value, _DIGITS)


def _correction(analysis: Analysis) -> str:
    name = analysis.options.correction
    if CORRECTIONS[name] is None:
        return "none (each p-value is read alone)"
    what = {"holm": "Holm–Bonferroni", "bonferroni": "Bonferroni",
            "fdr-bh": "Benjamini–Hochberg (false discovery rate)"}
    return f"{what[name]}, within each family of tests (the hit-rate tests; the preference tests)"


def to_json(analysis: Analysis) -> dict[str, Any]:
    """``{"labels": {EMOTION: {CONDITION: {...}}}, "preference": {EMOTION: {...}}, ...}``."""
    options = analysis.options
    labels: dict[str, dict[str, Any]] = {}
    for result in analysis.results:
        labels.setdefault(result.emotion, {})[result.condition] = {
            "n": result.answers,
            "hits": result.hits,
            "hit_rate": _number(result.hit_rate),
            "ci": [_number(result.ci[0]), _number(result.ci[1])],
            "p": _number(result.p),
            "p_adjusted": _number(result.p_adjusted),
            "significant": result.significant,
            "kappa": _number(result.kappa),
            "strongest_confusion": None if result.confusion is None else {
                "label": result.confusion, "n": result.confused, "p": _number(result.confusion_p),
                "p_adjusted": _number(result.confusion_p_adjusted),
                "hits_exceed": result.confusion_p_adjusted < options.alpha and result.hits > result.confused,
            },
        }
    return {
        "answers": analysis.answers,
        "participants": analysis.participants,
        "files": list(analysis.files),
        "labels_offered": list(analysis.labels),
        "labels_from": analysis.labels_source,
        "chance": None if analysis.chance is None else _number(analysis.chance),
        "ci": {"method": options.ci, "level": options.level},
        "alpha": options.alpha,
        "correction": options.correction,
        "preference_test": options.preference_test,
        "labels": labels,
        "confusion": {
            c.condition: {"emotions": list(c.emotions), "labels": list(c.labels), "counts": [list(r) for r in c.counts]}
            for c in analysis.confusions
        },
        "agreement": {
            a.condition: {"fleiss_kappa": None if a.kappa is None else _number(a.kappa), "subjects": a.subjects,
                          "subject": a.subject, "ratings": a.ratings, **({"reason": a.reason} if a.reason else {})}
            for a in analysis.agreements
        },
        "preference": {
            p.emotion: {"n": p.answers, "mse": p.chosen, "against": p.against, "share": _number(p.share),
                        "ci": [_number(p.ci[0]), _number(p.ci[1])], "p": _number(p.p),
                        "p_adjusted": _number(p.p_adjusted), "significant": p.significant,
                        "left_share": _number(p.left_share)}
            for p in analysis.preferences
        },
    }


def _p(value: float) -> str:
    return "< 0.001" if value < 0.001 else f"{value:.3f}"


def _percent(value: float) -> str:
    return f"{100 * value:.1f} %"


def _confusion(result: LabelResult) -> str:
    if result.confusion is None:
        return "none | –"
    return f"{result.confusion} ({result.confused}) | {_p(result.confusion_p_adjusted)}"


def to_markdown(analysis: Analysis, pictures: Mapping[str, str] | None = None) -> str:
    """The report; ``pictures``: condition -> file name of its heatmap (beside the report)."""
    options = analysis.options
    level = f"{100 * options.level:g} %"
    lines = [
        "# Perception study: analysis",
        "",
        f"{analysis.answers} answers from {analysis.participants} participants"
        + (f" ({len(analysis.files)} file{'s' if len(analysis.files) != 1 else ''})." if analysis.files else "."),
        "",
        "## Method",
        "",
        f"- Labels offered ({len(analysis.labels)}, from {analysis.labels_source}): {', '.join(analysis.labels)}; "
        f"chance = 1/{len(analysis.labels)} = {_percent(analysis.chance)}." if analysis.chance is not None
        else "- No label answers (no recognition statistics).",
        f"- Hit rate: answers naming the intended emotion; {level} {_CI_NAMES[options.ci]} interval; "
        "one-sided exact binomial test against chance. Every answer counts as one trial (answers of one "
        "participant to several stimuli or turns are treated as independent).",
        "- Strongest confusion: the other label chosen most often; the hits against it by an exact "
        "binomial test among the answers giving either (McNemar's exact test, as in the paper).",
        "- κ: the unbiased hit rate of the MSE paper's equation (1), κ = ((h + cr) − r_exp) / (i·j − h_exp), "
        "with r_exp = i·j / labels and h_exp = answers to the emotion / labels.",
        "- Agreement: Fleiss' κ over the participants' labels, per condition.",
        "- Believability: share of the pairs in which the MSE stimulus was chosen; "
        f"{_TEST_NAMES[options.preference_test]}.",
        f"- Multiple comparisons: {_correction(analysis)}; significant means adjusted p < {options.alpha:g}.",
        "",
    ]
    if analysis.results:
        lines += ["## Recognition", "",
                  "| emotion | condition | n | hits | hit rate | " + level + " CI | p | adjusted p | κ (eq. 1) "
                  "| strongest confusion | adjusted p |",
                  "|---|---|---:|---:|---:|---|---:|---:|---:|---|---:|"]
        for r in analysis.results:
            mark = " *" if r.significant else ""
            lines.append(f"| {r.emotion} | {r.condition} | {r.answers} | {r.hits} | {_percent(r.hit_rate)}{mark} | "
                         f"{_percent(r.ci[0])} – {_percent(r.ci[1])} | {_p(r.p)} | {_p(r.p_adjusted)} | "
                         f"{r.kappa:.3f} | {_confusion(r)} |")
        lines += ["", f"\\* above chance (adjusted p < {options.alpha:g}).", ""]
        above = sum(r.significant for r in analysis.results)
        lines += [f"{above} of {len(analysis.results)} emotion × condition cells are recognised above chance.", ""]
    for confusion, agreement in zip(analysis.confusions, analysis.agreements, strict=True):
        lines += [f"## Confusion matrix: {confusion.condition}", "",
                  "Rows: the emotion shown; columns: the label chosen; counts (row %).", "",
                  "| shown \\ chosen | " + " | ".join(confusion.labels) + " | n |",
                  "|---|" + "---:|" * (len(confusion.labels) + 1)]
        for emotion, counts in zip(confusion.emotions, confusion.counts, strict=True):
            total = sum(counts)
            cells = [f"**{c} ({round(100 * c / total)})**" if label == emotion else f"{c} ({round(100 * c / total)})"
                     for label, c in zip(confusion.labels, counts, strict=True)]
            lines.append(f"| {emotion} | " + " | ".join(cells) + f" | {total} |")
        lines.append("")
        if pictures and confusion.condition in pictures:
            lines += [f"![confusion matrix, {confusion.condition}]({pictures[confusion.condition]})", ""]
        if agreement.kappa is None:
            lines += [f"Fleiss' κ: not defined ({agreement.reason}).", ""]
        else:
            lines += [f"Fleiss' κ = {agreement.kappa:.3f} ({agreement.subjects} {agreement.subject} subjects, "
                      f"{agreement.ratings} answers each).", ""]
    if analysis.preferences:
        lines += ["## Believability", "",
                  "| emotion | against | n | chose MSE | share | " + level + " CI | p | adjusted p | verdict |",
                  "|---|---|---:|---:|---:|---|---:|---:|---|"]
        for p in analysis.preferences:
            if not p.significant:
                verdict = "no preference shown"
            else:
                verdict = "MSE more believable" if p.share > 0.5 else f"{p.against} more believable"
            lines.append(f"| {p.emotion} | {p.against} | {p.answers} | {p.chosen} | {_percent(p.share)} | "
                         f"{_percent(p.ci[0])} – {_percent(p.ci[1])} | {_p(p.p)} | {_p(p.p_adjusted)} | {verdict} |")
        left = sum(round(p.left_share * p.answers) for p in analysis.preferences)
        total = sum(p.answers for p in analysis.preferences)
        lines += ["", f"The left stimulus was chosen in {left} of {total} pairs ({_percent(left / total)}).", ""]
    return "\n".join(lines)
