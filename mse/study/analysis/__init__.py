"""``mse study analyze``: a perception study's answers (results CSV) to hit rates, κ, confusion
matrices, agreement and believability preferences (docs/study-analysis.md).

Reading (:mod:`.results`) needs nothing beyond mse; the statistics and the pictures need the
``study`` extra (scipy, statsmodels, Pillow)."""
