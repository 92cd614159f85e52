"""The objectives a request may name, written once (the command line reads them from here
without loading the solvers).

:data:`DEFAULT_OBJECTIVE` follows the signals' probability profiles, as every backend does
by default (the CP-SAT backend by perturb-and-MAP, docs/solvers.md); a request says it with
``objective=None``.  The others are the exact backends' (docs/solvers.md, "Objectives").
"""

DEFAULT_OBJECTIVE = "profile"
#: likely: the most probable timeline; random: ignore the probabilities; most-signals and
#: fewest-signals: as many or as few signals as possible.
OBJECTIVES = ("likely", "random", "most-signals", "fewest-signals")
