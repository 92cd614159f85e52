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
    """The lexeme sources named by export options."""
    return FaceSources(tuple(options.lexicon), options.face_library, options.head_library)
