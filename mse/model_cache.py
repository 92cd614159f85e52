"""The compiled-model cache: a behaviour-set file compiled once loads without lxml or lark.

Entries are the canonical IR JSON (``mse compile`` output) in ``$MSE_CACHE_DIR`` (default
``$XDG_CACHE_HOME/mse/models`` or ``~/.cache/mse/models``), named by a hash of the mse
version, the file's absolute path and its exact bytes: any edit is a miss.  A damaged or
unwritable cache is ignored, never an error.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
from collections.abc import Callable
from pathlib import Path

from mse import __version__
from mse.diagnostics import Diagnostic, MseError
from mse.fileio import user_cache_dir, write_atomic
from mse.ir.decode import DecodeError, model_from_trusted_json
from mse.ir.model import Model

Compile = Callable[[Path], tuple[Model | None, list[Diagnostic]]]


def cache_dir() -> Path:
    return user_cache_dir("models")


def _key(path: Path, data: bytes) -> str:
    digest = hashlib.sha256()
    for part in (__version__.encode(), str(path.resolve()).encode(), data):
        digest.update(len(part).to_bytes(8, "little"))
        digest.update(part)
    return digest.hexdigest()[:32]


def load_cached(path: Path, compile_source: Compile) -> Model:
    """The model of ``path``, from the cache when its bytes compiled before."""
    try:
        data = path.read_bytes()
    except OSError:
        data = None
    entry = cache_dir() / f"{_key(path, data)}.json" if data is not None else None
    if entry is not None:
        with contextlib.suppress(OSError, ValueError, DecodeError):
            return model_from_trusted_json(json.loads(entry.read_text(encoding="utf-8")))
    model, diagnostics = compile_source(path)
    if model is None:
        raise MseError(diagnostics)
    if entry is not None:
        from mse.ir.canonical import model_dumps

        with contextlib.suppress(OSError):
            write_atomic(entry, model_dumps(model))
    return model
