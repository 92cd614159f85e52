"""Every shell example in README.md and docs/**/*.md runs (issue 18 item 2).

Extracted: whole fenced ```sh / ```bash / ```console blocks, and the lines starting with
``mse `` in any other fenced block.  A block right after ``<!-- illustrative: REASON -->`` is
not run (used only where running is impossible; the reason is visible in the page source);
a block right after ``<!-- run-by: .ci/run -->`` is the set-up command CI runs itself, and
the test checks that ``.ci/run`` still says it.

Each page runs in a fresh folder laid out like a checkout next to the reference data:
``work/`` (the current folder) with ``behaviour_sets``, ``bench`` and ``tests`` (links to the
checkout's) and ``docs/images/`` (empty: the pictures' recipe writes there), and ``shared`` ->
``$MSE_SHARED`` beside it, so that ``../shared/...`` in an example resolves.  docs/motion.md
takes "your own set" and its timeline as given: :func:`_prepare` writes ``my_set.xml`` (the
bundled anger) and ``timeline.json`` (sampled from it).  Commands of one page run in order in that
folder (a later line may read what an earlier one wrote).  A command whose trailing comment
starts with ``# exit N`` must exit with N; every other one must exit 0.  The page's
```python blocks then run, in that folder, in one namespace (docs/api.md's have their own test).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent
PAGES = [REPO_ROOT / "README.md", *sorted((REPO_ROOT / "docs").rglob("*.md"))]
SHELL_LANGUAGES = {"sh", "bash", "console", "shell"}
FENCE = re.compile(r"^\s*```(\S*)\s*$")
MARKER = re.compile(r"<!--\s*(illustrative|run-by)\b[^>]*-->")
EXIT = re.compile(r"#\s*exit (\d+)\b")


@dataclass(frozen=True)
class Command:
    page: str
    line: int
    text: str
    expected_exit: int


@dataclass(frozen=True)
class Block:
    page: str
    line: int
    language: str
    body: list[str]
    marker: str | None


def blocks(page: Path) -> list[Block]:
    lines = page.read_text(encoding="utf-8").split("\n")
    found: list[Block] = []
    index = 0
    while index < len(lines):
        opening = FENCE.match(lines[index])
        if opening is None:
            index += 1
            continue
        end = index + 1
        while end < len(lines) and not FENCE.match(lines[end]):
            end += 1
        before = next((lines[i] for i in range(index - 1, -1, -1) if lines[i].strip()), "")
        marker = MARKER.search(before)
        found.append(
            Block(page.name, index + 1, opening.group(1), lines[index + 1 : end], marker.group(1) if marker else None)
        )
        index = end + 1
    return found


def _split(block: Block, every_line: bool) -> list[Command]:
    """Commands of a block: continuation lines (``\\``) and here-documents stay together."""
    commands: list[Command] = []
    index = 0
    body = block.body
    while index < len(body):
        first = index
        text = body[index]
        if not text.strip() or text.lstrip().startswith("#") or not (every_line or text.startswith("mse ")):
            index += 1
            continue
        parts = [text]
        heredoc = re.search(r"<<-?\s*'?(\w+)'?", text)
        while parts[-1].rstrip().endswith("\\") and index + 1 < len(body):
            index += 1
            parts.append(body[index])
        if heredoc:
            while index + 1 < len(body) and body[index].strip() != heredoc.group(1):
                index += 1
                parts.append(body[index])
        index += 1
        joined = "\n".join(parts)
        expected = EXIT.search(parts[-1].split("#", 1)[1]) if "#" in parts[-1] else None
        expected = expected or EXIT.search(joined.split("\n")[0])
        commands.append(Command(block.page, block.line + 1 + first, joined, int(expected.group(1)) if expected else 0))
    return commands


def commands(page: Path) -> list[Command]:
    found: list[Command] = []
    for block in blocks(page):
        if block.marker is not None:
            continue
        shell = block.language in SHELL_LANGUAGES
        found.extend(_split(block, every_line=shell))
    return found


def _mse(folder: Path, *args: str) -> None:
    subprocess.run([sys.executable, "-m", "mse", *args], cwd=folder, check=True, capture_output=True, timeout=120)


def _prepare(root: Path, shared: Path) -> Path:
    work = root / "work"
    (work / "docs" / "images").mkdir(parents=True)
    (root / "shared").symlink_to(shared, target_is_directory=True)
    for name in ("behaviour_sets", "bench", "tests"):
        (work / name).symlink_to(REPO_ROOT / name, target_is_directory=True)
    # "your own set": the bundled anger (it has motion leaves), under another name
    shutil.copyfile(REPO_ROOT / "behaviour_sets" / "anger.xml", work / "my_set.xml")
    _mse(work, "sample", "my_set.xml", "--duration", "4", "--seed", "1", "-o", "timeline.json")
    return work


def _environment() -> dict[str, str]:
    path = f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"
    return {**os.environ, "PATH": path, "PYTHONPATH": str(REPO_ROOT), "COLUMNS": "100"}


def python_blocks(page: Path) -> list[Block]:
    """Python blocks of the page (docs/api.md has its own test: tests/test_cli_newcomer.py)."""
    if page.name == "api.md":
        return []
    return [b for b in blocks(page) if b.language == "python" and b.marker is None]


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PAGES if commands(p) or python_blocks(p)], ids=lambda p: p.name)
def test_every_shell_example_runs(
    page: Path, tmp_path: Path, shared_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The page's shell commands in order, then its Python blocks in the same folder."""
    work = _prepare(tmp_path, shared_dir)
    environment = _environment()
    report: list[str] = []
    for command in commands(page):
        began = time.perf_counter()
        result = subprocess.run(
            ["bash", "-c", command.text],
            cwd=work,
            env=environment,
            stdin=subprocess.DEVNULL,
            capture_output=True,
            timeout=180,
        )
        took = time.perf_counter() - began
        report.append(f"{took:6.1f} s  {command.page}:{command.line}  {command.text.splitlines()[0][:70]}")
        assert result.returncode == command.expected_exit, (
            f"{command.page}:{command.line}: `{command.text}` exited {result.returncode}, "
            f"expected {command.expected_exit}\n{result.stderr.decode(errors='replace')[-2000:]}"
        )
    print("\n".join(report))
    monkeypatch.chdir(work)
    namespace: dict[str, object] = {}
    for block in python_blocks(page):
        exec(compile("\n".join(block.body), f"{block.page}:{block.line} (python)", "exec"), namespace)


def test_examples_are_found_and_markers_are_rare() -> None:
    every = [c for page in PAGES for c in commands(page)]
    assert len(every) > 60
    marked = [b for page in PAGES for b in blocks(page) if b.marker is not None]
    assert len(marked) <= 4, [f"{b.page}:{b.line}" for b in marked]


def test_set_up_blocks_are_what_ci_runs() -> None:
    ci = (REPO_ROOT / ".ci" / "run").read_text(encoding="utf-8").replace(" -q", "").replace("'", "")
    marked = 0
    for page in PAGES:
        for block in blocks(page):
            if block.marker == "run-by":
                marked += 1
                for line in block.body:
                    for step in (s.strip() for s in line.split("&&")):
                        wanted = step.replace(" -q", "").replace("'", "")
                        assert wanted in ci, f"{block.page}:{block.line}: .ci/run does not run {step}"
    assert marked == 2


def test_readme_pictures_are_what_their_recipe_makes(tmp_path: Path) -> None:
    """docs/export.md says how the README's timeline picture is made: making it again gives
    the committed file (after a change of the sampler that changes this timeline, run
    ``python docs/images/make_pictures.py`` and look at the three pictures)."""
    environment = _environment()
    subprocess.run(
        ["mse", "sample", "embarrassment", "--seed", "5461", "--format", "svg", "-o", "timeline.svg"],
        cwd=tmp_path,
        env=environment,
        check=True,
        capture_output=True,
        timeout=120,
    )
    made = (tmp_path / "timeline.svg").read_text(encoding="utf-8")
    committed = (REPO_ROOT / "docs" / "images" / "timeline.svg").read_text(encoding="utf-8")
    assert made == committed, "the README picture is stale: run python docs/images/make_pictures.py"


@pytest.mark.slow
def test_readme_format_example_lints_clean(tmp_path: Path) -> None:
    """The README's format example is a whole behaviour set: it compiles and lints clean."""
    text = (REPO_ROOT / "README.md").read_text(encoding="utf-8")
    example = re.search(r"```xml\n(.*?)```", text, flags=re.S)
    assert example is not None
    path = tmp_path / "format.xml"
    path.write_text(example.group(1), encoding="utf-8")
    result = subprocess.run(
        ["mse", "lint", str(path), "--strict"], env=_environment(), capture_output=True, timeout=120
    )
    assert result.returncode == 0, result.stdout.decode() + result.stderr.decode()
