"""The ``.vrma`` tracks played by their real consumer: npm's ``@pixiv/three-vrm-animation`` in
headless Chromium (issue 30).

``tests/three_vrm_player.html`` loads each file with three.js' GLTFLoader and the
``VRMAnimationLoaderPlugin``, binds it to a VRM built in code with ``createVRMAnimationClip`` and
plays it on an ``AnimationMixer``.  Every file must load with one animation and no warning, and
what the avatar shows at each frame (expression weights, neck and head rotations, look-at yaw and
pitch) must be the track model's values.  ``$MSE_SHARED/avatars/test.vrma``, a file from
three-vrm's authors, goes through the same page as a control.
"""

from __future__ import annotations

import functools
import http.server
import shutil
import subprocess
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import mse.api
from mse.export import render_bytes
from mse.export.tracks.model import Tracks, sample
from mse.export.tracks.vrma import NECK_SHARE, _quaternions, expression_weights
from mse.resources import bundled_names
from mse.sampling import sample as sample_timeline
from mse.timeline import Timeline
from tests.test_tracks import dialogue

pytestmark = pytest.mark.slow

PLAYER = Path(__file__).resolve().parent / "three_vrm_player.html"
#: The npm packages the page imports (three-vrm-core comes with three-vrm-animation; named so that
#: both resolve to one version).
PACKAGES = ("three@>=0.160", "@pixiv/three-vrm-animation@^3", "@pixiv/three-vrm-core@^3")
SEEDS = range(20)


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: Any) -> None:
        pass


@pytest.fixture(scope="module")
def player_root(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, str]]:
    """A folder with the npm packages and the player page, served over HTTP on localhost (module
    scripts do not load from file://)."""
    if shutil.which("npm") is None:
        pytest.skip("npm not on PATH: three-vrm-animation cannot be installed")
    folder = tmp_path_factory.mktemp("three-vrm")
    done = subprocess.run(
        ["npm", "install", "--silent", "--no-audit", "--no-fund", *PACKAGES],
        cwd=folder, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    if done.returncode != 0:
        pytest.skip(f"npm install of three-vrm-animation failed: {done.stderr.strip()[:300]}")
    shutil.copyfile(PLAYER, folder / "index.html")
    (folder / "files").mkdir()
    handler = functools.partial(_QuietHandler, directory=str(folder))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield folder, f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()


@pytest.fixture(scope="module")
def player(driver: Any, player_root: tuple[Path, str]) -> Any:
    _folder, url = player_root
    driver.get(f"{url}/index.html")
    driver.set_script_timeout(60)
    for _ in range(200):
        if driver.execute_script("return window.ready === true"):
            return driver
        threading.Event().wait(0.05)
    pytest.fail(f"the player page did not load its modules: {driver.get_log('browser')[-5:]}")


def play(player: Any, root: tuple[Path, str], name: str, data: bytes, frames: list[float]) -> dict[str, Any]:
    folder, url = root
    (folder / "files" / name).write_bytes(data)
    script = (
        "const done = arguments[arguments.length - 1];"
        "window.play(arguments[0], arguments[1]).then(done, e => done({error: String(e)}));"
    )
    result: dict[str, Any] = player.execute_async_script(script, f"{url}/files/{name}", frames)
    assert "error" not in result, f"{name}: {result['error']}"
    return result


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """Degrees between two rotations given as unit quaternions (x, y, z, w); from the chord, not
    arccos of the dot product, which float32 storage alone moves by 0.03 degrees."""
    chord = min(float(np.linalg.norm(a - b)), float(np.linalg.norm(a + b)))
    return float(np.degrees(4 * np.arcsin(min(1.0, chord / 2))))


def differences(tracks: Tracks, shown: list[dict[str, Any]], frames: list[int]) -> list[str]:
    """What the avatar showed that is not the track model's value at the same frame."""
    presets, customs = expression_weights(tracks)
    expected = {**presets, **customs}
    pitch, yaw, roll = tracks.head[:, 0], tracks.head[:, 1], tracks.head[:, 2]
    rest = 1.0 - NECK_SHARE
    neck = _quaternions(NECK_SHARE * yaw, NECK_SHARE * pitch, NECK_SHARE * roll)
    head = _quaternions(rest * yaw, rest * pitch, rest * roll)
    problems = []
    for frame, state in zip(frames, shown, strict=True):
        for name, weight in state["weights"].items():
            if abs(weight - expected[name][frame]) > 1e-5:
                problems.append(f"frame {frame} {name}: shown {weight:.5f}, track {expected[name][frame]:.5f}")
        for bone, quaternions in (("neck", neck), ("head", head)):
            off = _angle(np.array(state[bone]), quaternions[frame])
            if off > 0.01:
                problems.append(f"frame {frame} {bone}: {off:.3f} degrees off")
        for key, column in (("yaw", 0), ("pitch", 1)):
            if abs(state[key] - tracks.gaze[frame, column]) > 0.01:
                shown, track = state[key], tracks.gaze[frame, column]
                problems.append(f"frame {frame} look-at {key}: shown {shown:.3f}, track {track:.3f}")
    return problems


def check_played(player: Any, root: tuple[Path, str], name: str, timeline: Timeline, stride: int = 3) -> dict[str, Any]:
    tracks = sample(timeline)
    frames = list(range(0, tracks.frame_count, stride))
    result = play(player, root, name, render_bytes(timeline, "vrma"), [float(tracks.times[i]) for i in frames])
    assert result["animations"] == 1 and result["warnings"] == [], (name, result.get("warnings"))
    presets, customs = expression_weights(tracks)
    assert set(result["presets"]) == set(presets) and set(result["customs"]) == set(customs), name
    assert set(result["bones"]) >= {"neck", "head"} and result["lookAt"], name
    assert abs(result["duration"] - float(tracks.times[-1])) < 1e-4, name
    problems = differences(tracks, result["shown"], frames)
    assert problems == [], f"{name}: {problems[:5]}"
    return result


def test_the_reference_file_plays(player: Any, player_root: tuple[Path, str], shared_dir: Path) -> None:
    """The control: three-vrm's own sample animation loads on the same page, happy at 1 at 1.5 s."""
    reference = shared_dir / "avatars" / "test.vrma"
    if not reference.exists():
        pytest.skip(f"reference file not found: {reference}")
    result = play(player, player_root, "reference.vrma", reference.read_bytes(), [0.0, 1.5, 2.5])
    assert result["animations"] == 1 and result["warnings"] == []
    assert result["presets"] == ["happy"] and result["lookAt"]
    assert [round(s["weights"]["happy"], 5) for s in result["shown"]] == [0.0, 1.0, 0.0]
    assert abs(result["shown"][2]["yaw"] - 90.0) < 1e-3  # (0, 0.707, 0, 0.707): a quarter turn to the left


@pytest.mark.parametrize("name", bundled_names())
def test_every_bundled_set_plays_as_written(name: str, player: Any, player_root: tuple[Path, str]) -> None:
    model = mse.api.load(name, cache=True)
    for seed in SEEDS:
        timeline = sample_timeline(model, 10.0, seed=seed)
        check_played(player, player_root, f"{name}-{seed}.vrma", timeline, stride=1 if seed == 0 else 5)


def test_imported_greta_sets_play_as_written(player: Any, player_root: tuple[Path, str], greta_dir: Path) -> None:
    from mse.syntax.greta import import_greta

    expressions = import_greta(greta_dir / "lexicon.xml", greta_dir / "constraint.xml")
    assert len(expressions) >= 10
    for expression in expressions:
        model = mse.api.loads(expression.xml, path=f"{expression.name}.xml")
        for seed in SEEDS:
            timeline = sample_timeline(model, 10.0, seed=seed)
            check_played(player, player_root, f"greta-{expression.name}-{seed}.vrma", timeline, stride=5)


def test_a_dialogue_plays_as_written(player: Any, player_root: tuple[Path, str]) -> None:
    """Several episodes, an unannounced change of emotion: the curves the avatar plays are the model's."""
    result = check_played(player, player_root, "dialogue.vrma", dialogue(3), stride=1)
    assert max(max(s["weights"].values()) for s in result["shown"]) > 0.3  # the face moves
    assert max(abs(s["yaw"]) + abs(s["pitch"]) for s in result["shown"]) > 1.0  # so do the eyes
