"""``mse study make``: the study folder, built in a temporary folder beside the target and
moved into place at the end (a failed or interrupted make leaves nothing behind).

Layout of a study folder::

    manifest.json        seed, settings, emotions, every stimulus with its commands and SHA-256,
                         every participant's order of trials
    index.html study.js study.css plan.js
                         the page (plan.js: the plan as a script, so the page also works from file://)
    stimuli/sNN.webm|png what participants see (VP9 WebM videos, PNG stills)
    timelines/sNN.json   the timeline of each stimulus (mse-timeline/1)
    results/             one CSV per participant (written by ``mse study serve``)

Each stimulus is made by ``mse`` commands (``mse sample`` then ``mse render``), run in this
process by the ``run`` callable the command line hands in, with paths relative to the study
folder; the manifest keeps them so that any stimulus can be regenerated alone
(:func:`regenerate`).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

from mse.diagnostics import Diagnostic, MseError, Span
from mse.study.design import (
    FACE_MODALITIES,
    OTHER,
    RESULT_COLUMNS,
    Emotion,
    Settings,
    Stimulus,
    apex,
    candidate_seeds,
    conditions,
    face_only,
    plan_participants,
    plan_stimuli,
    render_command,
)

MANIFEST = "manifest.json"
MANIFEST_FORMAT = "mse-study/1"
#: The folders of a study whose paths the commands name relative to the study folder.
_FOLDERS = ("timelines/", "stimuli/")

#: Runs one ``mse`` command (without the leading ``mse``); returns its exit code and what it
#: wrote on standard error.
Runner = Callable[[Sequence[str]], tuple[int, str]]


def _error(where: str, message: str, code: str = "E100") -> MseError:
    return MseError([Diagnostic(code, message, Span(where))])


def resolve_emotions(names: Sequence[str]) -> list[Emotion]:
    """The behaviour sets named (bundled names or paths), each compiled once to check it;
    MseError when one is unknown, does not compile, or two have the same name."""
    from mse.api import load, resolve_path

    emotions: list[Emotion] = []
    problems: list[Diagnostic] = []
    for name in names:
        try:
            path = resolve_path(name)
            model = load(name, cache=True)
        except MseError as error:
            problems += error.diagnostics
            continue
        source = str(path.resolve()) if Path(name).exists() else name
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
        if any(e.name == model.name for e in emotions):
            problems.append(Diagnostic("E100", f"emotion {model.name!r} is given twice", Span(name)))
            continue
        emotions.append(Emotion(model.name, source, digest))
    if problems:
        raise MseError(problems)
    return emotions


def _local(argv: Sequence[str], root: Path) -> list[str]:
    """A manifest command as run: without ``mse``, with the study's paths under ``root``."""
    return [str(root / arg) if arg.startswith(_FOLDERS) else arg for arg in argv[1:]]


def _run(run: Runner, argv: Sequence[str], root: Path) -> None:
    code, errors = run(_local(argv, root))
    if code != 0:
        shown = " ".join(argv)
        detail = errors.strip().splitlines()
        raise _error(shown, f"failed (exit {code}): {detail[-1] if detail else 'no message'}")


def _read_json(path: Path) -> Any:
    return json.loads(path.read_text(encoding="utf-8"))


def _write_face_timeline(root: Path, source: str, target: str) -> None:
    derived = face_only(_read_json(root / source))
    (root / target).write_text(json.dumps(derived, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")


def build_stimulus(stimulus: Stimulus, root: Path, run: Runner, settings: Settings,
                   made: dict[str, Stimulus]) -> Stimulus:
    """Make one stimulus under ``root``; returns it with its final commands (an image's
    render at the apex) and apex."""
    if stimulus.derived_from is not None:  # face-only: cut from its MSE timeline
        source = made[stimulus.derived_from]
        _write_face_timeline(root, source.timeline, stimulus.timeline)
        render = render_command(stimulus.timeline, stimulus.file, settings)
        _run(run, render, root)
        return replace(stimulus, commands=(render,))
    for argv in stimulus.commands:
        _run(run, argv, root)
    if stimulus.condition != "image":
        return stimulus
    at = apex(_read_json(root / stimulus.timeline))
    render = render_command(stimulus.timeline, stimulus.file, settings, at)
    _run(run, render, root)
    return replace(stimulus, apex=at, commands=(*stimulus.commands, render))


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def manifest(emotions: Sequence[Emotion], settings: Settings, stimuli: Sequence[Stimulus], root: Path,
             command: Sequence[str]) -> dict[str, Any]:
    from mse import __version__

    participants = plan_participants(stimuli, settings.participants)
    entries = []
    for s in stimuli:
        entry: dict[str, Any] = {
            "id": s.id, "emotion": s.emotion, "condition": s.condition, "index": s.index, "seed": s.seed,
            "kind": s.kind, "file": s.file, "timeline": s.timeline,
        }
        if s.apex is not None:
            entry["apex"] = s.apex
        if s.derived_from is not None:
            entry["derived_from"] = s.derived_from
            entry["keep_modalities"] = list(FACE_MODALITIES)
        entry["commands"] = [list(argv) for argv in s.commands]
        entry["sha256"] = _sha256(root / s.file)
        entries.append(entry)
    return {
        "format": MANIFEST_FORMAT,
        "mse_version": __version__,
        "command": list(command),
        "seed": settings.seed,
        "duration": settings.duration,
        "size": list(settings.size),
        "fps": settings.fps,
        "stimuli_per_condition": settings.per_condition,
        "conditions": list(conditions(settings)),
        "emotions": [asdict(e) for e in emotions],
        "labels": [*(e.name for e in emotions), OTHER],
        "columns": list(RESULT_COLUMNS),
        "stimuli": entries,
        "participants": [
            {"id": p.id, "labels": list(p.labels), "pairs": [asdict(pair) for pair in p.pairs]}
            for p in participants
        ],
    }


def _check_target(out: Path, force: bool, emotions: Sequence[Emotion]) -> None:
    """A new or empty folder; with ``force``, also a study folder made before (never another
    folder, the current one or one holding a behaviour set of this study: all of it is replaced)."""
    where = str(out)
    if out.exists() and not out.is_dir():
        raise _error(where, "cannot write the study: exists and is not a folder")
    if not (out.is_dir() and any(out.iterdir())):
        return
    if not force:
        raise _error(where, "the study folder is not empty (give --force to replace a study made before)")
    if not (out / MANIFEST).is_file():
        raise _error(where, f"--force replaces only a study folder (with a {MANIFEST}); this one is not: "
                     "remove it yourself or choose another")
    inside = out.resolve()
    for held in (Path.cwd(), *(Path(e.source) for e in emotions if Path(e.source).is_absolute())):
        if held.resolve().is_relative_to(inside):
            raise _error(where, f"--force would delete {held}: choose another folder")


def stimulus_seeds(emotions: Sequence[Emotion], settings: Settings) -> dict[tuple[int, int], int]:
    """The seed of each emotion's stimulus ``k``: the first candidate whose MSE draw shows a face
    signal.  A draw of a set may be empty or show no face at all (every signal is optional), and
    such a stimulus carries no expression to judge; the seed the manifest records regenerates it."""
    from mse.api import load
    from mse.sampling import sample

    seeds: dict[tuple[int, int], int] = {}
    for e, emotion in enumerate(emotions):
        model = load(emotion.source, cache=True)
        for k in range(settings.per_condition):
            candidates = list(candidate_seeds(emotions, settings, e, k))
            seeds[e, k] = next(
                (seed for seed in candidates
                 if any(s.modality == "face" for s in sample(model, settings.duration, seed=seed).signals)),
                candidates[0],
            )  # fmt: skip
    return seeds


def make_study(names: Sequence[str], out: Path, settings: Settings, run: Runner, *, force: bool = False,
               command: Sequence[str] = ()) -> dict[str, Any]:
    """Build the study folder ``out``; returns its manifest.  Errors raise MseError and
    leave ``out`` as it was."""
    from mse.study.page import write_page

    emotions = resolve_emotions(names)
    _check_target(out, force, emotions)
    try:
        parent = out.resolve().parent
        parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{out.name[:100]}.", suffix=".tmp", dir=parent))
    except OSError as error:
        raise _error(str(out), f"cannot write the study: {error.strerror or error}") from None
    try:
        for folder in ("timelines", "stimuli", "results"):
            (staging / folder).mkdir()
        made: dict[str, Stimulus] = {}
        for stimulus in plan_stimuli(emotions, settings, stimulus_seeds(emotions, settings)):
            made[stimulus.id] = build_stimulus(stimulus, staging, run, settings, made)
        result = manifest(emotions, settings, list(made.values()), staging, command)
        (staging / MANIFEST).write_text(json.dumps(result, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
        write_page(staging, result)
        os.chmod(staging, 0o777 & ~_umask())
        _replace_folder(staging, out)
    except OSError as error:
        raise _error(str(out), f"cannot write the study: {error.strerror or error}") from None
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return result


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _replace_folder(staging: Path, out: Path) -> None:
    """Move the finished study into place: a rename, the old folder (``--force``) set aside
    first and removed once the new one is in place."""
    old = None
    if out.exists():
        old = Path(tempfile.mkdtemp(prefix=f".{out.name[:100]}.", suffix=".old", dir=staging.parent))
        os.rmdir(old)
        os.rename(out, old)
    try:
        os.rename(staging, out)
    except OSError:
        if old is not None:
            os.rename(old, out)
        raise
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def read_manifest(folder: Path) -> dict[str, Any]:
    """The manifest of a study folder; MseError when the folder is not one."""
    path = folder / MANIFEST
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise _error(str(folder), f"not a study folder (no {MANIFEST}; make one with mse study make)") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise _error(str(path), f"cannot read the manifest: {error}") from None
    if not isinstance(data, dict) or data.get("format") != MANIFEST_FORMAT:
        raise _error(str(path), f"not an {MANIFEST_FORMAT} manifest")
    return data


def regenerate(folder: Path, stimulus_id: str, root: Path, run: Runner) -> Path:
    """Make stimulus ``stimulus_id`` of the study in ``folder`` again, under ``root``, from
    the manifest's commands alone; returns the new file (compare it with the study's)."""
    data = read_manifest(folder)
    stimuli = {entry["id"]: entry for entry in data["stimuli"]}
    if stimulus_id not in stimuli:
        raise _error(str(folder), f"no stimulus {stimulus_id!r} in the manifest")
    entry = stimuli[stimulus_id]
    for name in ("timelines", "stimuli"):
        (root / name).mkdir(parents=True, exist_ok=True)
    if "derived_from" in entry:
        source = stimuli[entry["derived_from"]]
        _run(run, source["commands"][0], root)
        _write_face_timeline(root, source["timeline"], entry["timeline"])
    for argv in entry["commands"]:
        _run(run, argv, root)
    return root / str(entry["file"])
