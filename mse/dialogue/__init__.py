"""Dialogues: scripts of emotion changes and utterances, planned incrementally into one
multi-episode timeline (docs/dialogue.md).  Sits above the solvers, below the CLI."""
