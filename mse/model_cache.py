"""The compiled-model cache: a behaviour-set file compiled once loads without lxml or lark.

Where: ``$MSE_CACHE_DIR/models`` (default ``$XDG_CACHE_HOME/mse/models`` or
``~/.cache/mse/models``), used only when that folder belongs to this user and nobody else
can write it or swap a folder above it (:func:`mse.fileio.private_folder`).

Why it cannot change an answer: an entry is named by a hash of the code that compiles
(mse's version and the bytes of the grammar, the schema, the top-level modules and
every module of the syntax and ir layers), the file's path (as given and absolute) and its exact bytes; the entry
repeats all of these and a SHA-256 of the model text it holds, and every one is checked on
reading.  Any mismatch, damage, truncation, oversize, deep nesting or decoding problem is
a miss: the file is compiled again (from the same bytes that were hashed) and the entry
rewritten atomically.  A failed write is ignored, never an error.
"""

from __future__ import annotations

import functools
import hashlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mse import __version__
from mse.diagnostics import Diagnostic, MseError
from mse.fileio import private_folder, user_cache_dir, write_atomic
from mse.input_files import read_input
from mse.ir.decode import DecodeError, model_from_trusted_json
from mse.ir.model import Model
from mse.limits import MAX_INPUT_BYTES
from mse.resources import grammar_dir

#: ``compile_source(path, data)``; with ``data`` None it reads (and reports on) the file.
Compile = Callable[[Path, bytes | None], tuple[Model | None, list[Diagnostic]]]

FORMAT = "mse-model-cache/3"
#: The code that decides what a file compiles to: the package's top-level modules and the
#: syntax and ir layers, whole (tests/test_architecture.py keeps these layers from importing
#: anything above them), so no change to a module they use can leave a stale entry.
_COMPILER_PACKAGES = ("syntax", "ir")


def cache_dir() -> Path:
    return user_cache_dir("models")


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def compiler_sources() -> list[Path]:
    """The files whose bytes make up :func:`compiler_fingerprint`."""
    package = Path(__file__).resolve().parent
    sources = sorted(package.glob("*.py"))
    for name in _COMPILER_PACKAGES:
        sources += sorted((package / name).rglob("*.py"))
    grammar = grammar_dir()
    return [*sources, grammar / "constraints.lark", grammar / "mse.xsd"]


@functools.cache
def compiler_fingerprint() -> str:
    """A hash of mse's version, of the source of every module that reads and builds a model
    and of the grammar and schema (computed once per process, about 1 ms)."""
    digest = hashlib.sha256(__version__.encode())
    package = Path(__file__).resolve().parent
    for path in compiler_sources():
        name = path.relative_to(package) if path.is_relative_to(package) else Path(path.name)
        digest.update(name.as_posix().encode() + b"\0")
        try:
            digest.update(path.read_bytes())
        except OSError:
            digest.update(b"<missing>")
    return digest.hexdigest()


def _identity(path: Path, data: bytes) -> dict[str, str]:
    return {
        "format": FORMAT,
        "compiler": compiler_fingerprint(),
        "path": str(path),
        "absolute_path": str(path.resolve()),
        "source_sha256": _sha256(data),
    }


def _key(identity: dict[str, str]) -> str:
    return _sha256(json.dumps(identity, sort_keys=True).encode())[:40]


def _read_entry(entry: Path, identity: dict[str, str]) -> Model | None:
    """The model in ``entry`` if every check passes, else None (a miss)."""
    try:
        raw = read_input(entry, limit=4 * MAX_INPUT_BYTES, what="cache entry", record=False)
        envelope: Any = json.loads(raw)
        if not isinstance(envelope, dict) or any(envelope.get(k) != v for k, v in identity.items()):
            return None
        text = envelope.get("model")
        if not isinstance(text, str) or envelope.get("model_sha256") != _sha256(text.encode("utf-8")):
            return None
        return model_from_trusted_json(json.loads(text))
    except (MseError, ValueError, RecursionError, DecodeError, UnicodeError):
        return None


def load_cached(path: Path, compile_source: Compile) -> Model:
    """The model of ``path``, from the cache when these exact bytes compiled before."""
    try:
        data = read_input(path, what="behaviour-set file")
    except MseError:
        data = None
    folder = cache_dir()
    if data is None or not private_folder(folder):
        model, diagnostics = compile_source(path, data)
        if model is None:
            raise MseError(diagnostics)
        return model
    identity = _identity(path, data)
    entry = folder / f"{_key(identity)}.json"
    cached = _read_entry(entry, identity)
    if cached is not None:
        return cached
    model, diagnostics = compile_source(path, data)  # the very bytes that were hashed
    if model is None:
        raise MseError(diagnostics)
    from mse.ir.canonical import model_dumps

    try:
        text = model_dumps(model)
        envelope = {**identity, "model_sha256": _sha256(text.encode("utf-8")), "model": text}
        write_atomic(entry, json.dumps(envelope, ensure_ascii=False), durable=False)
    except (MseError, UnicodeError):
        pass  # an unwritable cache only costs time
    return model
