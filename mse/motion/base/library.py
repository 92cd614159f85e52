"""Motion libraries: labelled BVH clips (action, style, performer).

Two on-disk layouts are read by :func:`load_library`:

- a plain index, ``library.json`` beside the clips::

      {"format": "mse-motion-library/1",
       "emotion_styles": {"anger": "furious"},          # optional override of the table
       "clips": [{"file": "bow_angry_1.bvh", "action": "bow", "style": "angry",
                  "performer": "p1", "id": "optional, defaults to the file stem"}]}

  or ``library.csv`` with the header ``file,action,style,performer``;
- the Bandai Namco dataset layout: ``data/dataset-N_{action}_{style}_{id}.bvh`` (N = 1 or 2)
  with a JSON sidecar ``{"content": i, "style": j}`` of 0-based indices into
  ``cfg/content_label.txt`` and ``cfg/style_label.txt`` (labels there read ``dataset-1_bow``;
  the prefix is dropped). The
  sidecar wins over the file name. Bandai does not say which of its three actors performed a
  clip, so every clip is its own performance (``performer`` = the clip id).

Emotions of expressions map to style labels through :data:`EMOTION_STYLES` (see
``docs/motion.md``); a library index or a caller may override entries.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import os
import re
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

from mse.diagnostics import Diagnostic, MseError, Span
from mse.input_files import decode_utf8, note_read, read_input, read_json
from mse.limits import MAX_CSV_FIELD
from mse.motion.base import cache
from mse.motion.base.bvh import Motion, read_bvh

LIBRARY_FORMAT = "mse-motion-library/1"

#: Emotion (expression name) -> style label. Bandai's styles are normal, happy, sad, angry,
#: proud, not-confident, tired, active (+ masculinity, feminine, childish, old, musical,
#: giant, chimpira, which no emotion maps to).
EMOTION_STYLES: Mapping[str, str] = {
    # the four
    "anger": "angry",
    "cheerfulness": "happy",
    "pride": "proud",
    "embarrassment": "not-confident",
    # high-arousal negative, outward: like anger
    "small_anger": "angry",
    "hate": "angry",
    "disgust": "angry",
    "contempt": "angry",
    "envy": "angry",
    # positive valence: happy
    "joy": "happy",
    "joystrong": "happy",
    "small_joy": "happy",
    "happiness": "happy",
    "rejoice": "happy",
    "rejoices": "happy",
    "amusement": "happy",
    # negative, withdrawn, low dominance: not-confident
    "shame": "not-confident",
    "anxiety": "not-confident",
    "worried": "not-confident",
    "fear": "not-confident",
    "panic_fear": "not-confident",
    "tension": "not-confident",
    # loss: sad
    "sadness": "sad",
    "small_sadness": "sad",
    "despair": "sad",
    "regret": "sad",
    "disappointment": "sad",
    # low arousal: tired (relief is a slackening, an exhale)
    "bored": "tired",
    "relief": "tired",
    # high arousal, neither positive nor negative: active
    "surprise": "active",
    "interest": "active",
    # no emotion
    "neutral": "normal",
}
DEFAULT_STYLE = "normal"


def style_for_emotion(emotion: str, overrides: Mapping[str, str] | None = None) -> str:
    """The style label for an expression's emotion (unknown emotions -> ``normal``)."""
    key = emotion.strip().lower()
    key = key.removeprefix("emotion-")
    table = {**EMOTION_STYLES, **{k.lower(): v for k, v in (overrides or {}).items()}}
    return table.get(key, DEFAULT_STYLE)


class MotionUnavailable(Exception):
    """A library cannot serve a request (no clip of the action or style); callers may fall
    back (to the starter library, to another method)."""


@dataclass(frozen=True, slots=True)
class Clip:
    """One labelled clip; ``source`` is its file, or ``starter:<id>`` for generated clips."""

    id: str
    action: str
    style: str
    performer: str
    source: str


def _load_file(source: str) -> Motion:
    stat = os.stat(source)
    key = (os.path.abspath(source), stat.st_size, stat.st_mtime_ns)
    return cache.remembered(("motion", *key), lambda: read_bvh(source))


@dataclass(frozen=True, eq=False)
class MotionLibrary:
    """Clips with labels; motions load lazily and are cached per process."""

    name: str
    clips: tuple[Clip, ...]
    emotion_styles: Mapping[str, str] = field(default_factory=dict)
    preloaded: Mapping[str, Motion] = field(default_factory=dict)
    #: for in-memory clips: what they are made from (cached models follow its changes)
    fingerprint: str = ""

    def motion(self, clip: Clip) -> Motion:
        if clip.id in self.preloaded:
            return self.preloaded[clip.id]
        return _load_file(clip.source)

    def actions(self) -> list[str]:
        return sorted({c.action for c in self.clips})

    def styles(self) -> list[str]:
        return sorted({c.style for c in self.clips})

    def action_named(self, name: str) -> str:
        """The library's spelling of an action named in a behaviour set: action names there
        are identifiers, so ``wave_both_hands`` names Bandai's ``wave-both-hands`` (``-`` and
        ``_`` are the same letter here); ``name`` itself when no action matches."""
        if any(c.action == name for c in self.clips):
            return name
        key = name.replace("-", "_")
        return next((a for a in self.actions() if a.replace("-", "_") == key), name)

    def select(self, action: str | None = None, style: str | None = None) -> list[Clip]:
        return [c for c in self.clips if (action is None or c.action == action) and (style is None or c.style == style)]

    def clip(self, clip_id: str) -> Clip | None:
        return next((c for c in self.clips if c.id == clip_id), None)

    def style_for(self, emotion: str, overrides: Mapping[str, str] | None = None) -> str:
        return style_for_emotion(emotion, {**self.emotion_styles, **(overrides or {})})

    @cached_property
    def content_hash(self) -> str:
        """Fingerprint of labels and clip contents (file size + mtime; for in-memory clips,
        the id and the library's ``fingerprint``)."""
        digest = hashlib.sha256(self.name.encode())
        digest.update(self.fingerprint.encode())
        for clip in sorted(self.clips, key=lambda c: c.id):
            digest.update(f"{clip.id}|{clip.action}|{clip.style}|{clip.performer}".encode())
            if clip.id not in self.preloaded:
                stat = os.stat(clip.source)
                digest.update(f"|{stat.st_size}|{stat.st_mtime_ns}".encode())
        return digest.hexdigest()[:16]


def _error(message: str, path: str | os.PathLike[str], line: int = 0) -> MseError:
    return MseError([Diagnostic("E100", message, Span(os.fspath(path), line, 1 if line else 0))])


_DATASET_PREFIX = re.compile(r"^dataset-\d+_")


def _label(text: str) -> str:
    return _DATASET_PREFIX.sub("", text.strip())


_BANDAI_NAME = re.compile(r"^dataset-\d+_(?P<action>.+)_(?P<style>[^_]+)_(?P<take>\d+)$")


def read_bandai(root: str | os.PathLike[str]) -> MotionLibrary:
    """The Bandai layout: ``cfg/*_label.txt`` and ``data/dataset-N_*.bvh`` + JSON sidecars
    (dataset 1 and dataset 2 share it)."""
    base = Path(root)
    data = base / "data" if (base / "data").is_dir() else base
    cfg = base / "cfg"
    contents = [_label(x) for x in _read_text(cfg / "content_label.txt").split("\n") if x.strip()]
    styles = [_label(x) for x in _read_text(cfg / "style_label.txt").split("\n") if x.strip()]
    clips = []
    for path in sorted(data.glob("dataset-*_*.bvh")):
        match = _BANDAI_NAME.match(path.stem)
        if match is None:
            continue
        action, style = match.group("action"), match.group("style")
        sidecar = path.with_suffix(".json")
        if sidecar.is_file():
            labels = read_json(sidecar, what="Bandai label sidecar")
            try:
                content_index, style_index = labels["content"], labels["style"]
                if not all(isinstance(i, int) and not isinstance(i, bool) for i in (content_index, style_index)):
                    raise TypeError("'content' and 'style' must be whole numbers")
                if content_index < 0 or style_index < 0:
                    raise IndexError("negative label index")
                action = contents[content_index]
                style = styles[style_index]
            except (ValueError, KeyError, IndexError, TypeError) as error:
                raise _error(f"invalid Bandai label sidecar: {error}", sidecar, 1) from None
        clips.append(Clip(path.stem, action, style, path.stem, str(path)))
    if not clips:
        raise _error("no dataset-N_*.bvh clips found", data)
    return MotionLibrary(base.name or str(base), tuple(clips))


def _read_text(path: Path) -> str:
    """A small text file of a library: regular, size-capped, UTF-8 (E100 otherwise)."""
    name = os.fspath(path)
    return decode_utf8(read_input(name, what="library file"), name, what="library file")


@contextlib.contextmanager
def _csv_field_limit() -> Iterator[None]:
    previous = csv.field_size_limit(MAX_CSV_FIELD)
    try:
        yield
    finally:
        csv.field_size_limit(previous)


def _clips_from_rows(rows: Iterable[tuple[int, Mapping[str, Any]]], index: Path) -> list[Clip]:
    clips = []
    for line, row in rows:
        missing = [k for k in ("file", "action", "style") if not isinstance(row.get(k), str)]
        if missing:
            raise _error(f"clip entry lacks {', '.join(missing)}", index, line)
        if "\x00" in str(row["file"]):
            raise _error("clip file name holds a NUL character", index, line)
        source = index.parent / str(row["file"])
        if not source.is_file():
            raise _error(f"clip file not found: {row['file']}", index, line)
        clip_id = str(row.get("id") or source.stem)
        performer = str(row.get("performer") or "unknown")
        clips.append(Clip(clip_id, str(row["action"]), str(row["style"]), performer, str(source)))
    return clips


def read_index(index: str | os.PathLike[str]) -> MotionLibrary:
    """A ``library.json`` or ``library.csv`` index (see the module docstring)."""
    path = Path(index)
    overrides: dict[str, str] = {}
    if path.suffix == ".csv":
        reader = csv.DictReader(io.StringIO(_read_text(path), newline=""))
        try:
            with _csv_field_limit():
                rows = [(number + 2, row) for number, row in enumerate(reader)]
        except csv.Error as error:
            raise _error(f"invalid CSV: {error}", path, reader.line_num) from None
        clips = _clips_from_rows(rows, path)
    else:
        decoded = read_json(path, what="library index")
        if not isinstance(decoded, dict) or not isinstance(decoded.get("clips"), list):
            raise _error("a library index is an object with a 'clips' list", path, 1)
        if decoded.get("format", LIBRARY_FORMAT) != LIBRARY_FORMAT:
            raise _error(f"unsupported library format {decoded.get('format')!r}", path, 1)
        raw = decoded.get("emotion_styles", {})
        if isinstance(raw, dict):
            overrides = {str(k): str(v) for k, v in raw.items()}
        entries = decoded["clips"]
        if not all(isinstance(e, dict) for e in entries):
            raise _error("every clip entry must be an object", path, 1)
        clips = _clips_from_rows(((0, e) for e in entries), path)
    if len({c.id for c in clips}) != len(clips):
        raise _error("duplicate clip ids in the library index", path)
    return MotionLibrary(path.parent.name, tuple(clips), overrides)


def load_library(location: str | os.PathLike[str]) -> MotionLibrary:
    """A library folder (``library.json``/``.csv`` or the Bandai layout) or an index file.

    Its clips count as read by the command (:func:`mse.input_files.note_read`) even when a
    cache spares reading them, so no output of the command can replace one."""
    library = _load_library(location)
    for clip in library.clips:
        note_read(clip.source)
    return library


def _load_library(location: str | os.PathLike[str]) -> MotionLibrary:
    path = Path(location)
    if path.is_file():
        return read_index(path)
    if not path.is_dir():
        raise _error("motion library not found", path)
    for name in ("library.json", "library.csv"):
        if (path / name).is_file():
            return read_index(path / name)
    if (path / "cfg" / "content_label.txt").is_file():
        return read_bandai(path)
    raise _error("not a motion library: no library.json, library.csv or Bandai cfg/ folder", path)
