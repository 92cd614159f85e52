"""Options shared by every exporter (kept apart from ``__init__`` so exporters can import it)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

#: BML 1.0 composition policies; Greta spells them in lower case and calls MERGE "blend".
COMPOSITIONS: tuple[str, ...] = ("MERGE", "APPEND", "REPLACE")


@dataclass(frozen=True)
class ExportOptions:
    """How a timeline is written out.

    ``face_library`` is a Greta ``facelibrary.xml``: face lexemes resolve to FACS action
    units through it.  ``bml_extensions`` allows elements outside BML 1.0 core
    (``ext:faceFacs``); the default output is BML 1.0 core.
    ``bml_constraints`` adds ``<constraint>`` blocks as metadata only (times stay absolute).
    ``motion_base_dir`` is the folder that ``signal.motion["file"]`` paths are relative to.
    ``realizer`` is the profile BML is written for (``generic``, ``greta``, ``asap``; None:
    the format's default, see :mod:`mse.export.realizers`); ``library_dir`` is the folder of
    that realizer's libraries (Greta's BehaviorLexicon), read in place to check names.
    ``head_library`` (Greta ``HeadGestures.xml``) and ``lexicon`` (the user's lexeme tables,
    TOML, see docs/face.md) tell the face player what lexemes do.
    """

    character_id: str = "Agent"
    face_library: Path | None = None
    bml_extensions: bool = False
    bml_constraints: bool = False
    motion_base_dir: Path | None = None
    composition: str = "MERGE"
    gaze_target: str = "camera"
    title: str | None = None
    figure_fps: int = 30
    realizer: str | None = None
    library_dir: Path | None = None
    head_library: Path | None = None
    lexicon: tuple[Path, ...] = ()
    #: The ``<bml id>`` (``--bml-id``); None: from the timeline (see ``behaviours.block_id``).
    block_id: str | None = None
