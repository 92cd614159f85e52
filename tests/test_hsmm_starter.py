"""HSMM leaves on the embedded starter library (no shared data needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mse.motion.base.starter import starter_library
from mse.motion.hsmm import leaf


@pytest.mark.slow
def test_starter_leaf_has_its_scheduled_duration(tmp_path: Path) -> None:
    library = starter_library()
    motion = leaf.synthesize_leaf(library, "bow", "sad", 2.0, seed=2, cache_dir=tmp_path)
    assert motion.frame_count == round(2.0 / motion.frame_time)
    assert np.all(np.isfinite(motion.values))
    assert motion.skeleton.same_layout(library.motion(library.select(action="bow")[0]).skeleton)
