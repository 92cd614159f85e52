"""The optional parts of mse and the packages they need (pyproject.toml, [project.optional-dependencies]).

``pip install mse`` compiles, checks, lints, samples (every solver) and exports text, BML,
SVG, HTML and ELAN.  Motion generation (``animate``, ``sample --animate``, ``style``) needs
the ``motion`` extra, video (``render``, ``--format mp4|webm|gif``) the ``video`` extra, and
``learn`` the ``learn`` extra, ``serve`` the ``serve`` extra.  Every import of one of their packages sits in a
``with require(EXTRA):`` block, so that a missing package says which extra to install::

    with require("video"):
        import av
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

#: The top-level modules each extra brings.
EXTRAS: dict[str, tuple[str, ...]] = {
    "motion": ("scipy", "sklearn", "hmmlearn"),
    "video": ("av", "aggdraw", "PIL"),
    "learn": ("scipy",),
    "serve": ("websockets",),
}


class MissingExtra(ImportError):
    """A package of an extra that is not installed; the command line says which extra."""

    def __init__(self, extra: str, module: str) -> None:
        self.extra = extra
        super().__init__(f"this needs the {extra!r} extra (no module {module!r}): pip install 'mse[{extra}]'",
                         name=module)


@contextlib.contextmanager
def require(extra: str) -> Iterator[None]:
    """Run the imports in the block; one of ``extra``'s packages missing raises :class:`MissingExtra`."""
    try:
        yield
    except ModuleNotFoundError as error:
        missing = (error.name or "").partition(".")[0]
        if missing not in EXTRAS[extra]:
            raise
        raise MissingExtra(extra, missing) from error
