"""The face player: a procedural face, head, gaze and torso driven by a timeline.

- :mod:`.rig` and ``rig.json``: the one description of the face geometry (points, per-unit
  displacements, shapes), evaluated with numpy here and by ``face.js`` in the page;
- :mod:`.lexicon` and ``lexicon.toml``: lexemes to action units and rotations;
- :mod:`.track`: occurrences to channel values over time (onset, apex, offset);
- :mod:`.page`: the face in the HTML viewer; :mod:`.raster`: the face in video frames.

See docs/face.md.
"""

from __future__ import annotations

from mse.export.face.lexicon import FaceSources, Resolver
from mse.export.options import ExportOptions

__all__ = ["FaceSources", "Resolver", "sources_of"]


def sources_of(options: ExportOptions) -> FaceSources:
    """The lexeme sources named by export options; Greta's libraries default to the ones in
    ``library_dir`` (its BehaviorLexicon folder, ``--library-dir``) when that folder has them."""
    from mse.export.realizer_libraries import FACE_LIBRARY_FILE, HEAD_GESTURES_FILE

    face, head = options.face_library, options.head_library
    if options.library_dir is not None:
        if face is None and (options.library_dir / FACE_LIBRARY_FILE).is_file():
            face = options.library_dir / FACE_LIBRARY_FILE
        if head is None and (options.library_dir / HEAD_GESTURES_FILE).is_file():
            head = options.library_dir / HEAD_GESTURES_FILE
    return FaceSources(tuple(options.lexicon), face, head)
