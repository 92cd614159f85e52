"""What both motion methods share: BVH I/O and forward kinematics, rotations, filters, body
parts, motion libraries (files, Bandai, the embedded starter), LMA descriptors, the
whole-timeline composition and the style recognizer of the evaluations.

Nothing here imports a method (:mod:`mse.motion.lma_hmm`, :mod:`mse.motion.hsmm`).
"""
