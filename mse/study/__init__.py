"""Perception studies of the generated expressions: stimuli, the study page, and the analysis of the answers."""
