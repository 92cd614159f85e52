"""VRM animation (.vrma) tracks: the layout three-vrm-animation reads (checked against the reference
file ``$MSE_SHARED/avatars/test.vrma``), values equal to the track model's, and Khronos'
glTF-Validator (npm ``gltf-validator``): 0 errors, 0 warnings."""

from __future__ import annotations

import json
import shutil
import struct
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import mse.api
from mse.export import render_bytes
from mse.export.tracks.model import AU_SCALE, sample
from mse.export.tracks.vrma import expression_weights, write_vrma
from mse.resources import bundled_names
from mse.sampling import sample as sample_timeline
from mse.timeline import Timeline, TimelineSignal
from tests.test_tracks import dialogue

#: VRM 1.0's preset expressions (VRMC_vrm-1.0, expressions.md).
VRM_PRESETS = {
    "happy", "angry", "sad", "relaxed", "surprised", "aa", "ih", "ou", "ee", "oh", "blink", "blinkLeft",
    "blinkRight", "lookUp", "lookDown", "lookLeft", "lookRight", "neutral",
}  # fmt: skip
_VALIDATE = """
const validator = require('gltf-validator');
const fs = require('fs');
(async () => {
  const out = [];
  for (const file of process.argv.slice(2)) {
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)));
    out.push({file, errors: report.issues.numErrors, warnings: report.issues.numWarnings,
              messages: report.issues.messages.filter(m => m.severity <= 1).slice(0, 5)});
  }
  console.log(JSON.stringify(out));
})();
"""


def read_glb(data: bytes) -> tuple[dict[str, Any], bytes]:
    magic, version, total = struct.unpack_from("<4sII", data)
    assert magic == b"glTF" and version == 2 and total == len(data)
    length, kind = struct.unpack_from("<I4s", data, 12)
    assert kind == b"JSON" and length % 4 == 0
    document = json.loads(data[20 : 20 + length])
    blength, bkind = struct.unpack_from("<I4s", data, 20 + length)
    assert bkind == b"BIN\0" and blength % 4 == 0 and 28 + length + blength == len(data)
    return document, data[28 + length : 28 + length + blength]


def accessor(document: dict[str, Any], binary: bytes, index: int) -> np.ndarray:
    spec = document["accessors"][index]
    view = document["bufferViews"][spec["bufferView"]]
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[spec["type"]]
    values = np.frombuffer(binary, "<f4", spec["count"] * width, view.get("byteOffset", 0))
    return values.reshape(spec["count"], width) if width > 1 else values


def loader_problems(data: bytes) -> list[str]:
    """What three-vrm-animation's loader (VRMAnimationLoaderPlugin, $MSE_SHARED/avatars/README.md)
    would refuse or warn about."""
    document, _ = read_glb(data)
    problems = []
    if "VRMC_vrm_animation" not in document.get("extensionsUsed", []):
        problems.append("VRMC_vrm_animation not in extensionsUsed")
    extension = document["extensions"]["VRMC_vrm_animation"]
    if extension.get("specVersion") != "1.0":
        problems.append(f"specVersion {extension.get('specVersion')}")
    bones = {v["node"]: k for k, v in extension.get("humanoid", {}).get("humanBones", {}).items()}
    expressions = {v["node"] for group in extension.get("expressions", {}).values() for v in group.values()}
    look = extension.get("lookAt", {}).get("node")
    if "hips" in bones.values():
        hips = next(n for n, b in bones.items() if b == "hips")
        if abs(document["nodes"][hips].get("translation", [0, 0, 0])[1]) < 1e-3:
            problems.append("rest hips at zero")
    for animation in document["animations"]:
        for channel in animation["channels"]:
            node, path = channel["target"]["node"], channel["target"]["path"]
            if node in expressions and path != "translation":
                problems.append(f"expression node {node}: {path}")
            if node == look and path != "rotation":
                problems.append(f"lookAt: {path}")
            if node in bones and path == "translation" and bones[node] != "hips":
                problems.append(f"bone {bones[node]}: translation")
    return problems


def test_the_reference_file_passes_the_loader_rules(shared_dir: Path) -> None:
    reference = shared_dir / "avatars" / "test.vrma"
    if not reference.exists():
        pytest.skip(f"reference file not found: {reference}")
    assert loader_problems(reference.read_bytes()) == []


def test_vrma_layout_and_values() -> None:
    timeline = dialogue(2)
    tracks = sample(timeline)
    data = render_bytes(timeline, "vrma")
    assert data == write_vrma(tracks)
    assert loader_problems(data) == []
    document, binary = read_glb(data)
    extension = document["extensions"]["VRMC_vrm_animation"]
    presets, customs = extension["expressions"]["preset"], extension["expressions"].get("custom", {})
    assert set(presets) <= VRM_PRESETS and {"happy", "angry", "sad", "surprised", "blink", "lookLeft"} <= set(presets)
    assert all(name.startswith("AU") and name not in VRM_PRESETS for name in customs)
    assert set(extension["humanoid"]["humanBones"]) >= {"hips", "neck", "head"}
    preset_weights, custom_weights = expression_weights(tracks)
    node_of = {v["node"]: k for group in (presets, customs) for k, v in group.items()}
    (animation,) = document["animations"]
    seen = set()
    for channel in animation["channels"]:
        sampler = animation["samplers"][channel["sampler"]]
        times = accessor(document, binary, sampler["input"])
        assert np.allclose(times, tracks.times, atol=1e-6) and sampler["interpolation"] == "LINEAR"
        node = channel["target"]["node"]
        values = accessor(document, binary, sampler["output"])
        if node in node_of:
            name = node_of[node]
            expected = preset_weights.get(name, custom_weights.get(name))
            assert np.allclose(values[:, 0], expected, atol=1e-6) and not values[:, 1:].any()
            seen.add(name)
        else:
            assert np.allclose(np.linalg.norm(values, axis=1), 1.0, atol=1e-5)  # unit quaternions
    assert seen == set(node_of.values())
    for name, weights in custom_weights.items():
        assert np.allclose(weights, tracks.unit(int(name[2:])) / AU_SCALE)


def test_head_and_gaze_turn_the_right_way() -> None:
    timeline = Timeline("t", 2.0, (TimelineSignal("h", "head", "head=head_left", 0.0, 2.0),
                                   TimelineSignal("g", "gaze", "gaze=look_left", 0.0, 2.0)))  # fmt: skip
    document, binary = read_glb(render_bytes(timeline, "vrma"))
    extension = document["extensions"]["VRMC_vrm_animation"]
    head = extension["humanoid"]["humanBones"]["head"]["node"]
    look = extension["lookAt"]["node"]
    (animation,) = document["animations"]
    for channel in animation["channels"]:
        if channel["target"]["node"] in (head, look):
            x, y, z, _w = accessor(document, binary, animation["samplers"][channel["sampler"]]["output"])[30]
            assert y > 0.05 and abs(x) < 1e-6 and abs(z) < 1e-6  # about +y: towards the agent's left (+x)


@pytest.fixture(scope="module")
def gltf_validator(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with npm's gltf-validator installed (outside the repository)."""
    if shutil.which("npm") is None or shutil.which("node") is None:
        pytest.skip("npm/node not on PATH: glTF-Validator (npm gltf-validator) cannot run")
    folder = tmp_path_factory.mktemp("gltf-validator")
    done = subprocess.run(
        ["npm", "install", "--silent", "--no-audit", "--no-fund", "gltf-validator@^2.0.0-dev.3.10"],
        cwd=folder, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    if done.returncode != 0:
        pytest.skip(f"npm install gltf-validator failed: {done.stderr.strip()[:300]}")
    (folder / "validate.js").write_text(_VALIDATE, encoding="utf-8")
    return folder


@pytest.mark.slow
def test_gltf_validator_finds_no_error_or_warning(gltf_validator: Path, tmp_path: Path, shared_dir: Path) -> None:
    """Every bundled and imported Greta set, 20 seeds each, a dialogue, and three-vrm's own file."""
    from mse.syntax.greta import import_greta

    greta = shared_dir / "greta"
    models = [mse.api.load(name, cache=True) for name in bundled_names()]
    imported = import_greta(greta / "lexicon.xml", greta / "constraint.xml")
    models += [mse.api.loads(e.xml, path=f"{e.name}.xml") for e in imported]
    assert len(models) >= 18
    files = []
    timelines = [sample_timeline(model, 10.0, seed=seed) for model in models for seed in range(20)]
    for index, timeline in enumerate([*timelines, dialogue(3)]):
        path = tmp_path / f"{index}.vrma"
        path.write_bytes(render_bytes(timeline, "vrma"))
        files.append(str(path))
    reference = shared_dir / "avatars" / "test.vrma"
    if reference.exists():
        files.append(str(reference))
    done = subprocess.run(
        ["node", str(gltf_validator / "validate.js"), *files],
        cwd=gltf_validator, capture_output=True, text=True, timeout=300, check=True,
    )  # fmt: skip
    reports = json.loads(done.stdout)
    assert len(reports) == len(files) >= 380
    assert [r for r in reports if r["errors"] or r["warnings"]] == []
