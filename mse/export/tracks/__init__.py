"""Time-sampled curves for engines that play tracks instead of BML (docs/tracks.md).

- :mod:`.model`: one track model sampled at a frame rate (FACS action units 0-5, ARKit
  blendshape weights 0-1, head rotation and gaze angles in degrees), read from the face
  player's own curves (:meth:`mse.export.face.track.Track.values`);
- :mod:`.openface`: OpenFace 2.0 FeatureExtraction CSV (714 columns), as Greta reads it;
- :mod:`.arkit`: Live Link Face's CSV layout and a JSON form, with ``arkit.toml`` (Apple's
  52 blendshape names and the action unit -> blendshape table).
"""
