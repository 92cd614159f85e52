"""Lexemes to action units and rotations: the shipped table, user tables, Greta's libraries."""

from __future__ import annotations

from pathlib import Path

import pytest

from mse.api import load
from mse.diagnostics import MseError
from mse.export.face.greta_head import load_head_gestures
from mse.export.face.lexicon import FaceSources, Resolver, bundled_table, parse_table
from mse.resources import bundled_names


def _targets(resolver: Resolver, lexeme: str, modality: str = "") -> dict[str, float]:
    action = resolver.resolve(lexeme, modality)
    assert action is not None, lexeme
    return dict(action.targets)


def test_every_bundled_face_gaze_head_and_torso_lexeme_resolves() -> None:
    resolver = Resolver()
    missing = []
    for name in bundled_names():
        model = load(name)
        for signal in model.signals:
            if signal.modality in ("gesture",) or signal.motion is not None:
                continue  # the body shows these (motion leaves)
            if resolver.resolve(signal.lexeme, signal.modality) is None:
                missing.append(f"{name}: {signal.id} ({signal.lexeme})")
    assert not missing


def test_bundled_entries_drive_the_expected_channels() -> None:
    resolver = Resolver()
    smile = _targets(resolver, "faceexp=smile")
    assert smile["AU12:L"] == smile["AU12:R"] > 0.5
    assert _targets(resolver, "gaze=look_down")["gaze_y"] == 1.0
    assert _targets(resolver, "head=head_left")["head_yaw"] > 20  # the agent's left
    assert _targets(resolver, "torso=lean_forward")["torso_pitch"] > 0
    assert resolver.resolve("faceexp=neutral", "face") is not None  # mapped to nothing visible
    blink = resolver.resolve("faceexp=blinking", "face")
    assert blink is not None and blink.repeat is not None
    nod = resolver.resolve("head=nod", "head")
    assert nod is not None and nod.oscillate == (0.55, "bump")
    assert "AU4:L" in _targets(resolver, "FROWN")  # case-insensitive, BML core style
    assert "AU1:L" in _targets(resolver, "RAISE_BROWS")


def test_naming_rules_for_units_and_directions() -> None:
    resolver = Resolver()
    assert _targets(resolver, "faceexp=AU26") == {"AU26:L": 1.0, "AU26:R": 1.0}
    assert _targets(resolver, "AU12L") == {"AU12:L": 1.0}
    assert _targets(resolver, "gaze=look_down_left", "gaze") == {"gaze_x": 1.0, "gaze_y": 1.0}
    assert _targets(resolver, "head=head_up_right", "head")["head_yaw"] < 0
    assert resolver.resolve("gesture=wave_hello", "gesture") is None
    eyes = resolver.resolve("AU61", "gaze")
    assert eyes is not None and dict(eyes.targets) == {"gaze_x": 1.0}
    undrawable = resolver.resolve("faceexp=AU33", "face")
    assert undrawable is not None and undrawable.unsupported == (33,)


def test_user_tables_come_first_and_later_files_win(tmp_path: Path) -> None:
    first = tmp_path / "a.toml"
    first.write_text('[smile]\nau = { AU12 = 0.2 }\n[wave_hello]\ntorso = { roll = 5 }\n', encoding="utf-8")
    second = tmp_path / "b.toml"
    second.write_text('[smile]\nau = { AU12 = 0.4 }\n["gaze=look_down"]\ngaze = { y = 0.5 }\n', encoding="utf-8")
    resolver = Resolver(FaceSources(tables=(first, second)))
    assert _targets(resolver, "faceexp=smile")["AU12:L"] == 0.4
    assert _targets(resolver, "gesture=wave_hello") == {"torso_roll": 5.0}
    assert _targets(resolver, "gaze=look_down") == {"gaze_y": 0.5}  # full references match too
    assert _targets(resolver, "look_down")["gaze_y"] == 1.0  # ... only that class


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("[x]\nau = { AU12 = 'high' }\n", "must be a finite number"),
        ("[x]\nhead = { yaw = nan }\n", "must be a finite number"),
        ("[x]\ngaze = { x = 1e9 }\n", "out of range"),
        ("[x]\nau = { smile = 1 }\n", "must look like AU12"),
        ("[x]\nhead = { nod = 1 }\n", "is not one of"),
        ("[x]\ncolour = 'red'\n", "unknown key"),
        ("[x]\noscillate = { period = 0 }\n", "positive period"),
        ("[x\n", "not a valid TOML"),
        ("x = 1\n", "must be a table"),
    ],
)
def test_bad_tables_are_e214_diagnostics(text: str, fragment: str) -> None:
    with pytest.raises(MseError) as error:
        parse_table(text, "t.toml", "t.toml")
    assert error.value.diagnostics[0].code == "E214"
    assert fragment in error.value.diagnostics[0].message


def test_unreadable_table_is_e100(tmp_path: Path) -> None:
    with pytest.raises(MseError) as error:
        Resolver(FaceSources(tables=(tmp_path / "missing.toml",)))
    assert error.value.diagnostics[0].code == "E100"


def test_bundled_table_keys_are_unique_lower_case_names() -> None:
    table = bundled_table()
    assert all(key == key.lower() for key in table)
    assert {"smile", "frown", "look_down", "head_left", "bow", "blinking"} <= set(table)


@pytest.mark.shared
def test_greta_face_library_gives_action_units(greta_dir: Path) -> None:
    resolver = Resolver(FaceSources(face_library=greta_dir / "facelibrary.xml"))
    assert _targets(resolver, "faceexp=embarrassment_signal_6", "face") == {
        "AU12:L": 0.8,
        "AU12:R": 0.8,
        "AU6:L": 0.8,
        "AU6:R": 0.8,
    }
    looks = _targets(resolver, "gaze=look_down", "gaze")  # Greta's look_down: AU64 0.5 + AU43 0.2
    assert looks["gaze_y"] == 0.5 and looks["AU43:L"] == pytest.approx(0.2)
    neutral = resolver.resolve("faceexp=embarrassment_signal_9", "face")  # no actions: neutral
    assert neutral is not None and neutral.targets == ()
    anxiety = _targets(resolver, "faceexp=anxiety", "face")  # one-sided units
    assert anxiety == {"AU24:L": 1.0, "AU24:R": 0.5}


@pytest.mark.shared
def test_greta_head_gestures_give_rotations(greta_dir: Path) -> None:
    table = load_head_gestures(greta_dir / "HeadGestures.xml")
    down = dict(table["embarrassment_signal_1"].targets)  # SagittalTilt Forward 0.15..0.5
    assert down == {"head_pitch": pytest.approx(40.0 * 0.325)}
    left = dict(table["embarrassment_signal_2"].targets)  # VerticalTorsion Leftward
    assert left["head_yaw"] > 0
    assert table["nod"].oscillate == (0.6, "bump")
    assert table["shake_middle"].oscillate == (0.6, "sine")
    assert table["up"].oscillate is None and dict(table["up"].targets)["head_pitch"] < 0
    resolver = Resolver(FaceSources(head_library=greta_dir / "HeadGestures.xml"))
    assert "head_pitch" in _targets(resolver, "embarrassment_signal_1", "head")


def test_bad_head_library_is_a_diagnostic(tmp_path: Path) -> None:
    broken = tmp_path / "HeadGestures.xml"
    broken.write_text("<HeadGestures><head", encoding="utf-8")
    with pytest.raises(MseError) as error:
        load_head_gestures(broken)
    assert error.value.diagnostics[0].code == "E101"
    with pytest.raises(MseError) as error:
        load_head_gestures(tmp_path / "missing.xml")
    assert error.value.diagnostics[0].code == "E100"


@pytest.mark.shared
def test_library_dir_gives_the_face_player_gretas_libraries(greta_dir: Path) -> None:
    from mse.export import ExportOptions
    from mse.export.face import sources_of

    sources = sources_of(ExportOptions(library_dir=greta_dir))
    assert sources.face_library == greta_dir / "facelibrary.xml"
    assert sources.head_library == greta_dir / "HeadGestures.xml"
    mine = Path("mine.xml")
    assert sources_of(ExportOptions(library_dir=greta_dir, face_library=mine)).face_library == mine
