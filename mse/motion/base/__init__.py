"""What both motion methods share: BVH I/O and forward kinematics, rotations, filters, body
parts, motion libraries (files, Bandai, the embedded starter), LMA descriptors, the
whole-timeline composition, what an action's clips do (``cycles``), longer clips by
repetition (``loop``) and the one bounded in-process cache (``cache``). The evaluations'
fidelity measures and style recognizer are in ``bench/evaluation/``.

Nothing here imports a method (:mod:`mse.motion.lma_hmm`, :mod:`mse.motion.hsmm`).
"""
