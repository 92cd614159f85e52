"""The study page: ``index.html``, ``study.js`` and ``study.css`` (shipped beside this
module) and ``plan.js``, the study's plan as a script (a page opened from ``file://`` may
load scripts but not fetch JSON)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

_HERE = Path(__file__).resolve().parent
PAGE_FILES = ("index.html", "study.js", "study.css")


def plan(manifest: dict[str, Any]) -> dict[str, Any]:
    """What the page needs: the labels, each stimulus' file and truth, each participant's order."""
    return {
        "duration": manifest["duration"],
        "labels": manifest["labels"],
        "columns": manifest["columns"],
        "stimuli": {
            s["id"]: {"file": s["file"], "kind": s["kind"], "emotion": s["emotion"], "condition": s["condition"]}
            for s in manifest["stimuli"]
        },
        "participants": {
            p["id"]: {"labels": p["labels"], "pairs": p["pairs"]} for p in manifest["participants"]
        },
    }


def write_page(folder: Path, manifest: dict[str, Any]) -> None:
    for name in PAGE_FILES:
        (folder / name).write_bytes((_HERE / name).read_bytes())
    text = json.dumps(plan(manifest), indent=1, ensure_ascii=True).replace("</", "<\\/")
    (folder / "plan.js").write_text(f"window.STUDY = {text};\n", encoding="utf-8")
