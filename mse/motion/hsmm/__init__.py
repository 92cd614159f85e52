"""HSMM stylistic motion synthesis (Tilmanne et al.): average model, style adaptation
(CMLLR + MAP) and maximum-likelihood parameter generation with global variance.

Modules, bottom-up: ``features`` (exponential maps, Δ/ΔΔ windows), ``prep`` (clips to
aligned feature sequences, skeleton template), ``segment`` (steps of cyclic actions),
``model`` (left-to-right HSMM units, forced alignment, training), ``occupancy``
(forward-backward state posteriors), ``stats`` (hard/soft adaptation statistics), ``adapt``
(CMLLR with regression classes, MAP, adaptive training), ``mlpg`` (banded parameter
generation, global variance), ``synth`` (durations, generation, root from foot contacts,
BVH), ``io`` (npz + JSON), ``api``.
"""
