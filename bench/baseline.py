"""The one baseline of the speed benches: another version of ``mse``, measured in the same run.

The machine the benches run on is shared, so an absolute time says little; a ratio against
another version measured alternately in the same run says more.  Every bench that compares
takes ``--baseline REF`` (:func:`add_argument`), where ``REF`` is

* a git revision of this repository (a commit, a branch, a tag, ``HEAD~3``): its ``mse``,
  ``grammar`` and ``behaviour_sets`` are extracted with ``git archive`` into a temporary
  folder (no worktree, no change to the repository), or
* a path to another source tree (a checkout or an unpacked sdist: a folder holding ``mse/``).

Without ``--baseline`` nothing is compared.  :func:`baseline_tree` gives a folder whose only
package is that version's ``mse``; :func:`environment` runs a subprocess with it first on
``PYTHONPATH`` and this checkout after it, so that ``python -m bench.…`` still finds this
checkout's bench scripts while ``import mse`` gets the baseline.  :func:`run_python` runs
such a subprocess from a neutral folder (``-c`` and ``-m`` put the working folder first on
``sys.path``).
"""

from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
import tarfile
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

#: What a baseline tree holds: the package and the data it reads from beside it.
PACKAGE_PATHS = ("mse", "grammar", "behaviour_sets")

#: Subprocesses run from here: ``python -c``/``-m`` put the working folder first on sys.path.
NEUTRAL = tempfile.gettempdir()


def add_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--baseline",
        metavar="REF",
        default=None,
        help="another version to measure in the same run: a git revision or a path to a source tree",
    )


def extract(revision: str, into: Path) -> Path:
    """The package of ``revision`` (``git archive``) under ``into``; returns its root."""
    done = subprocess.run(
        ["git", "archive", "--format=tar", revision, "--", *PACKAGE_PATHS],
        cwd=REPO,
        capture_output=True,
        check=False,
    )
    if done.returncode != 0:
        raise SystemExit(f"baseline {revision!r}: {done.stderr.decode(errors='replace').strip()}")
    root = into / "baseline"
    root.mkdir(parents=True, exist_ok=True)
    with tarfile.open(fileobj=io.BytesIO(done.stdout)) as tar:
        tar.extractall(root, filter="data")
    return root


def link(tree: Path, into: Path) -> Path:
    """A folder under ``into`` whose entries link to the package paths of the source tree ``tree``."""
    if not (tree / "mse").is_dir():
        raise SystemExit(f"baseline {str(tree)!r}: not a source tree (no mse/ in it)")
    root = into / "baseline"
    root.mkdir(parents=True, exist_ok=True)
    for name in PACKAGE_PATHS:
        if (tree / name).exists():
            (root / name).symlink_to((tree / name).resolve(), target_is_directory=True)
    return root


@contextmanager
def baseline_tree(reference: str | None) -> Iterator[Path | None]:
    """The baseline's package folder for the run of a bench (None without a reference);
    removed afterwards."""
    if not reference:
        yield None
        return
    with tempfile.TemporaryDirectory(prefix="mse-baseline-") as folder:
        path = Path(reference).expanduser()
        yield link(path, Path(folder)) if path.is_dir() else extract(reference, Path(folder))


def environment(root: Path | None, **extra: str) -> dict[str, str]:
    """This process's environment with ``root``'s ``mse`` first on ``PYTHONPATH`` (None: this
    checkout's), then this checkout (for ``bench``), plus ``extra``."""
    paths = [str(root)] if root is not None else []
    paths.append(str(REPO))
    return {**os.environ, "PYTHONPATH": os.pathsep.join(paths), **extra}


def run_python(
    root: Path | None,
    arguments: Sequence[str],
    *,
    stdin: str | None = None,
    check: bool = False,
    **extra: str,
) -> subprocess.CompletedProcess[str]:
    """``python ARGUMENTS`` in a fresh interpreter that imports ``root``'s ``mse`` (None: this
    checkout's), from a neutral folder; text output captured."""
    return subprocess.run(
        [sys.executable, *arguments],
        input=stdin,
        env=environment(root, **extra),
        cwd=NEUTRAL,
        capture_output=True,
        text=True,
        check=check,
    )


def describe(reference: str | None) -> str:
    return reference or "none (--baseline REF to compare)"
