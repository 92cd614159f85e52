"""Readers of Greta's realizer libraries (mse.export.realizer_libraries)."""

from __future__ import annotations

from pathlib import Path

import pytest

from mse.diagnostics import MseError
from mse.export.lexemes import Lexeme
from mse.export.realizer_libraries import (
    axis_rotations,
    gestuary_path,
    load_face_library,
    load_gestuary,
    load_greta_libraries,
    load_head_gestures,
    load_torso_gestures,
)

FACE = """<?xml version="1.0"?>
<facelibrary>
  <expression class="faceexp" instance="Smile_Big_Open">
    <action intensity="0.8" name="AU12"/><action name="AU25" side="left"/>
  </expression>
  <expression class="gaze" instance="look_down"><action intensity="0.5" name="AU64"/></expression>
</facelibrary>
"""
HEAD = """<?xml version="1.0"?>
<HeadGestures>
  <head id="Nod_Middle" lexeme="NOD">
    <KeyPoint type="strokeEnd"><SagittalTilt direction="Forward" min="0.05" max="0.2"/></KeyPoint>
  </head>
  <head id="ShakeLeftUpRight" lexeme="ShakeLeftUpRight" repetition="2">
    <KeyPoint><VerticalTorsion direction="Leftward" min="0.1" max="0.3"/></KeyPoint>
    <KeyPoint><VerticalTorsion direction="Rightward" min="0.1" max="0.3"/></KeyPoint>
  </head>
  <headDirectionShift id="Forward"><SagittalTilt direction="Forward" min="0.0" max="0.5"/></headDirectionShift>
</HeadGestures>
"""
TORSO = """<?xml version="1.0"?>
<TorsoGestures>
  <torso id="BodyLean" lexeme="BodyLean"><KeyPoint type="strokeStart"><Rotations/></KeyPoint></torso>
  <torsoDirectionShift id="forward_lean">
    <SagittalTilt direction="Forward" amount="0.5" min="0.0" max="1.0"/>
  </torsoDirectionShift>
</TorsoGestures>
"""
GESTUARY = """<?xml version="1.0"?>
<gestuary>
  <gesture category="rest" id="akimbo"><phase><hand side="LEFT"/><hand side="RIGHT"/></phase></gesture>
  <gesture category="emotion" id="anger_signal_5"><phase><hand side="RIGHT"/></phase><phase/></gesture>
</gestuary>
"""


@pytest.fixture()
def library_dir(tmp_path: Path) -> Path:
    (tmp_path / "facelibrary.xml").write_text(FACE)
    (tmp_path / "HeadGestures.xml").write_text(HEAD)
    (tmp_path / "TorsoGestures.xml").write_text(TORSO)
    (tmp_path / "gestuary_poppy.xml").write_text(GESTUARY)
    return tmp_path


def test_face_library_keeps_spelling_and_resolves_case_insensitively(library_dir: Path) -> None:
    face = load_face_library(library_dir / "facelibrary.xml")
    assert face.instances("faceexp") == ["Smile_Big_Open"]
    units = face.resolve(Lexeme("faceexp", "smile_big_open"))
    assert units is not None
    assert [(u.number, u.intensity, u.side) for u in units] == [(12, 0.8, "BOTH"), (25, 1.0, "LEFT")]
    assert face.resolve(Lexeme("", "look_down")) is not None


def test_head_gestures_by_id_then_lexeme_with_rotations(library_dir: Path) -> None:
    head = load_head_gestures(library_dir / "HeadGestures.xml")
    nod = head.by_id("nod_middle")
    assert nod is not None and head.by_lexeme("nod") == nod
    assert nod.kind == "head" and nod.keypoints[0].type == "strokeEnd"
    assert axis_rotations(nod)["SagittalTilt"][0].maximum == 0.2
    shake = head.by_id("ShakeLeftUpRight")
    assert shake is not None and shake.repetition == 2 and len(shake.keypoints) == 2
    forward = head.by_id("forward")
    assert forward is not None and forward.kind == "headDirectionShift"
    assert forward.keypoints[0].rotations[0].direction == "Forward"
    assert head.ids() == ["Forward", "Nod_Middle", "ShakeLeftUpRight"]


def test_torso_and_gestuary(library_dir: Path) -> None:
    torso = load_torso_gestures(library_dir / "TorsoGestures.xml")
    assert torso.by_id("bodylean") is not None
    shift = torso.by_id("FORWARD_LEAN")
    assert shift is not None and shift.keypoints[0].rotations[0].amount == 0.5
    gestuary = load_gestuary(gestuary_path(library_dir))
    found = gestuary.find("REST=Akimbo")
    assert found is not None and found.hands == ("LEFT", "RIGHT") and found.phases == 1
    assert gestuary.find("gesture=akimbo") is None
    assert [g.reference for g in gestuary.with_id("anger_signal_5")] == ["emotion=anger_signal_5"]


def test_load_folder_and_errors(library_dir: Path) -> None:
    libraries = load_greta_libraries(library_dir)
    assert libraries.gestuary.path.endswith("gestuary_poppy.xml")
    (library_dir / "gestuary_other.xml").write_text(GESTUARY)
    with pytest.raises(MseError, match=r"E100.*gestuary_other\.xml, gestuary_poppy\.xml"):
        load_greta_libraries(library_dir)
    (library_dir / "gestuary.xml").write_text(GESTUARY)
    assert load_greta_libraries(library_dir).gestuary.path.endswith("gestuary.xml")
    with pytest.raises(MseError, match="E100"):
        load_greta_libraries(library_dir / "missing")
    (library_dir / "HeadGestures.xml").write_text("<HeadGestures><head id='x'>")
    with pytest.raises(MseError) as caught:
        load_greta_libraries(library_dir)
    (diagnostic,) = caught.value.diagnostics
    assert diagnostic.code == "E101" and diagnostic.span.path.endswith("HeadGestures.xml") and diagnostic.span.line == 1


def test_greta_stock_libraries(greta_dir: Path) -> None:
    libraries = load_greta_libraries(greta_dir)
    assert libraries.head.by_lexeme("NOD") is not None
    assert libraries.torso.by_id("TrunkTiltingForwards") is not None
    assert libraries.gestuary.find("emotion=embarrassment_signal_10") is not None
    assert libraries.face.resolve(Lexeme("faceexp", "joy")) is not None
