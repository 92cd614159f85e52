"""Dialogues: scripts of emotion changes and utterances, planned incrementally into one
multi-episode timeline (docs/dialogue.md).  Sits above the solvers, below the CLI."""

from mse.dialogue.script import EmotionEvent, EndEvent, Event, SayEvent, Word, parse_event, read_script
from mse.dialogue.session import HORIZON, Session, plan_script

__all__ = [
    "HORIZON", "EmotionEvent", "EndEvent", "Event", "SayEvent", "Session", "Word", "parse_event", "plan_script",
    "read_script",
]
