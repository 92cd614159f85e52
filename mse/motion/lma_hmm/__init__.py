"""The LMA + HMM method (Samadani et al.): RMLR saliency of LMA components, nearest
neighbours in the target style, HMM + Viterbi modulation of a desired motion path.

Modules: ``search`` (feature tables, RMLR, ε-neighbourhood), ``hmm`` (observations, HMM
training and decoding, regeneration), ``generate`` (the paper's Fig. 2 with caches).
"""
