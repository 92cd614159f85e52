"""Shared fixtures.  ``MSE_SHARED`` (default ``../shared`` beside the checkout) holds the
reference data that must never be copied into the repository; tests that need it skip with
a clear reason when it is absent (CI sets it, so CI never skips)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

TYPE_CHECKING = False
if TYPE_CHECKING:
    from mse.motion.base.library import MotionLibrary

# Property tests are deterministic by default (the "ci" profile: the same examples on every
# run, so that a red CI is reproducible and never a coin toss); HYPOTHESIS_PROFILE=explore
# draws fresh examples for bug hunting.
settings.register_profile("ci", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

REPO_ROOT = Path(__file__).resolve().parent.parent
FIXTURES = Path(__file__).resolve().parent / "fixtures"


def shared_root() -> Path | None:
    configured = os.environ.get("MSE_SHARED")
    root = Path(configured) if configured else REPO_ROOT.parent / "shared"
    return root if root.is_dir() else None


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    root = shared_root()
    if root is None:
        pytest.skip("reference data not found: set MSE_SHARED to the shared/ folder (CI does)")
    return root


@pytest.fixture(scope="session")
def greta_dir(shared_dir: Path) -> Path:
    path = shared_dir / "greta"
    if not path.is_dir():
        pytest.skip(f"Greta data not found in {shared_dir}")
    return path


@pytest.fixture(scope="session")
def bandai_dir(shared_dir: Path) -> Path:
    path = shared_dir / "motion" / "bandai-ds1"
    if not path.is_dir():
        pytest.skip(f"Bandai motion data not found in {shared_dir}")
    return path


@pytest.fixture(scope="session")
def bandai_ds2(shared_dir: Path) -> MotionLibrary:
    """Bandai dataset 2, loaded once for every test that reads it."""
    from mse.motion.base.library import load_library

    path = shared_dir / "motion" / "bandai-ds2"
    if not path.is_dir():
        pytest.skip(f"Bandai dataset 2 not found in {shared_dir}")
    return load_library(path)


@pytest.fixture(autouse=True, scope="session")
def _private_motion_cache(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Trained motion models and paths go to a test folder, never the user's cache (unless
    MSE_CACHE_DIR names one)."""
    if not os.environ.get("MSE_CACHE_DIR"):
        os.environ["MSE_CACHE_DIR"] = str(tmp_path_factory.mktemp("mse-cache"))

# The one headless Chromium of the browser tests (tests/test_export_browser.py defines it; a
# module-scoped fixture, so each module that asks for ``driver`` starts its own).
from tests.test_export_browser import driver  # noqa: E402, F401
