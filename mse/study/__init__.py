"""Perception studies of MSE stimuli (issue 34): ``mse study make`` builds the stimuli, the
counterbalanced orders and a self-contained page; ``mse study serve`` serves the page and
stores each participant's answers as one CSV (docs/study.md).

Modules: :mod:`.latin` (balanced Latin squares), :mod:`.design` (what is shown to whom, in
which order), :mod:`.make` (the study folder: stimuli, manifest, page), :mod:`.results`
(the results CSV), :mod:`.server` (the local HTTP server).
"""
