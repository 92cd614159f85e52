"""Relative links in README.md, CHANGELOG.md, docs/ and bench/README.md resolve: the file
exists and, for ``file.md#anchor``, the page has a heading with that anchor (GitHub's rule:
lower case, punctuation dropped, spaces to hyphens)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent
PAGES = sorted(
    [
        *(p for p in (REPO_ROOT / "README.md", REPO_ROOT / "CHANGELOG.md", REPO_ROOT / "bench" / "README.md")
          if p.exists()),
        *(REPO_ROOT / "docs").rglob("*.md"),
        *(REPO_ROOT / "bench" / "results").glob("*.md"),
    ]
)
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^\s*```")


def _prose(page: Path) -> str:
    """The page without its fenced code blocks and inline code."""
    kept, inside = [], False
    for line in page.read_text(encoding="utf-8").split("\n"):
        if FENCE.match(line):
            inside = not inside
            continue
        if not inside:
            kept.append(re.sub(r"`[^`]*`", "", line))
    return "\n".join(kept)


def anchor(heading: str) -> str:
    text = re.sub(r"`|\*|_(?=\W)|(?<=\W)_", "", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    found: set[str] = set()
    for line in page.read_text(encoding="utf-8").split("\n"):
        heading = re.match(r"^#{1,6}\s+(.*)$", line)
        if heading:
            base = anchor(heading.group(1))
            name, n = base, 1
            while name in found:
                name, n = f"{base}-{n}", n + 1
            found.add(name)
    return found


def links(page: Path) -> list[str]:
    return [m.group(1) for m in LINK.finditer(_prose(page))]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(REPO_ROOT)))
def test_relative_links_resolve(page: Path) -> None:
    broken = []
    for target in links(page):
        if re.match(r"^[a-z]+:", target) or target.startswith("//"):
            continue  # http(s), mailto: not checked here
        path_part, _, fragment = target.partition("#")
        destination = (page.parent / path_part).resolve() if path_part else page
        if not destination.exists():
            broken.append(f"{target}: no such file")
        elif fragment and destination.suffix == ".md" and fragment not in anchors(destination):
            broken.append(f"{target}: no heading with anchor #{fragment}")
    assert not broken, f"{page.relative_to(REPO_ROOT)}: " + "; ".join(broken)


def test_the_checker_sees_links() -> None:
    readme = links(REPO_ROOT / "README.md")
    assert "docs/semantics.md" in readme and len(readme) > 10
    assert anchor("Regenerating the pictures") == "regenerating-the-pictures"
