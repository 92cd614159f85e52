"""The statistics of a perception study, on counts (scipy.stats and statsmodels; the ``study`` extra).

Every function here takes counts and returns numbers; :mod:`mse.study.analysis.analyze` decides
what is counted.  docs/study-analysis.md gives each formula and why it was chosen.
"""

from __future__ import annotations

from collections.abc import Sequence

from mse.extras import require

#: Confidence-interval methods for a proportion: the name on the command line -> statsmodels' name.
CI_METHODS = {"wilson": "wilson", "clopper-pearson": "beta"}
#: Corrections for multiple comparisons: the name on the command line -> statsmodels' name (None: no correction).
CORRECTIONS: dict[str, str | None] = {"holm": "holm", "bonferroni": "bonferroni", "fdr-bh": "fdr_bh", "none": None}
#: Tests of a believability preference against 0.5: exact binomial, or the χ² goodness of fit the paper names.
PREFERENCE_TESTS = ("binomial", "chi2")


def proportion_interval(count: int, total: int, level: float, method: str) -> tuple[float, float]:
    """The ``level`` confidence interval of ``count / total`` (``method``: a key of :data:`CI_METHODS`)."""
    with require("study"):
        from statsmodels.stats.proportion import proportion_confint
    low, high = proportion_confint(count, total, alpha=1 - level, method=CI_METHODS[method])
    return float(low), float(high)


def above_chance(hits: int, total: int, chance: float) -> float:
    """One-sided exact binomial p-value of ``hits`` or more out of ``total`` at rate ``chance``."""
    with require("study"):
        from scipy.stats import binomtest
    return float(binomtest(hits, total, chance, alternative="greater").pvalue)


def hits_against_confusion(hits: int, confused: int) -> float:
    """Two-sided exact p-value that the intended label and the most chosen other one are chosen equally
    often: a binomial test among the answers giving either, which is McNemar's exact test (the paper's)
    on one multinomial sample."""
    if hits + confused == 0:
        return 1.0
    with require("study"):
        from scipy.stats import binomtest
    return float(binomtest(hits, hits + confused, 0.5).pvalue)


def preference_p(chosen: int, total: int, test: str) -> float:
    """Two-sided p-value of ``chosen`` out of ``total`` against an even choice (``test``: binomial or chi2)."""
    with require("study"):
        from scipy.stats import binomtest, chisquare
    if test == "chi2":
        return float(chisquare([chosen, total - chosen]).pvalue)
    return float(binomtest(chosen, total, 0.5).pvalue)


def adjusted(p_values: Sequence[float], correction: str) -> list[float]:
    """``p_values`` adjusted for multiple comparisons within their family (``correction``: a key of
    :data:`CORRECTIONS`; ``none`` returns them as they are)."""
    method = CORRECTIONS[correction]
    if method is None or not p_values:
        return list(p_values)
    with require("study"):
        from statsmodels.stats.multitest import multipletests
    return [float(p) for p in multipletests(list(p_values), method=method)[1]]


def unbiased_kappa(confusion: Sequence[Sequence[int]], row: int, column: int | None, labels: int) -> float:
    """κ of the paper's equation (1) for one emotion, read literally (docs/study-analysis.md)::

        κ = ((h + cr) − r_exp) / ((i · j) − h_exp)

    ``confusion``: answers, one row per presented emotion, one column per label; ``row``/``column``:
    the emotion's row and the column of its label (None: nobody could choose it).  h: hits;
    cr: correct rejections (answers to the other emotions' stimuli that are not this label);
    i · j: all answers (items times judges); r_exp = i · j / labels: the chance-expected number of
    responses with this label; h_exp = n / labels: the chance-expected hits among the n answers to
    this emotion's stimuli."""
    total = sum(sum(r) for r in confusion)
    answered = sum(confusion[row])
    hits = confusion[row][column] if column is not None else 0
    given = sum(r[column] for r in confusion) if column is not None else 0
    rejections = (total - answered) - (given - hits)
    expected_responses = total / labels
    expected_hits = answered / labels
    return (hits + rejections - expected_responses) / (total - expected_hits)


def fleiss_kappa(table: Sequence[Sequence[int]]) -> float:
    """Fleiss' κ of a subjects × categories table of counts (every subject rated equally often)."""
    with require("study"):
        from statsmodels.stats.inter_rater import fleiss_kappa as statsmodels_fleiss

    return float(statsmodels_fleiss(table, method="fleiss"))
