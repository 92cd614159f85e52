"""``-o`` never destroys what it should not, and output is never partial (issue 13, items 2
and 13): every kind of target, inputs, modes, failures as ``path: E105 message``, no stray
temporary file on errors or SIGTERM, animation folders written whole or not at all."""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mse.cli import main
from mse.diagnostics import MseError
from mse.fileio import staged_folder, write_atomic

REPO = Path(__file__).resolve().parent.parent
RELIEF = REPO / "behaviour_sets" / "relief.xml"


def _no_temporaries(folder: Path) -> None:
    assert not [p for p in folder.rglob("*") if p.name.endswith(".tmp")]


def _compile_to(target: Path | str, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    code = main(["compile", str(RELIEF), "-o", str(target)])
    return code, capsys.readouterr().err


def test_regular_files_are_replaced_atomically_and_keep_their_mode(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "secret.json"
    target.write_text("old")
    target.chmod(0o600)
    assert _compile_to(target, capsys)[0] == 0
    assert stat.S_IMODE(target.stat().st_mode) == 0o600
    assert target.read_text().startswith("{")
    fresh = tmp_path / "new" / "fresh.json"  # missing folders are created
    assert _compile_to(fresh, capsys)[0] == 0
    assert stat.S_IMODE(fresh.stat().st_mode) == 0o666 & ~_umask()
    _no_temporaries(tmp_path)


def _umask() -> int:
    current = os.umask(0)
    os.umask(current)
    return current


def test_an_input_is_never_overwritten(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = tmp_path / "set.xml"
    source.write_bytes(RELIEF.read_bytes())
    alias = tmp_path / "alias.xml"
    alias.symlink_to(source)
    for target in (source, alias):
        assert main(["compile", str(source), "-o", str(target)]) == 1
        assert "E105" in capsys.readouterr().err
    assert main(["sample", str(source), "-o", str(source)]) == 1
    assert main(["lint", "--no-deep", str(tmp_path), "--format", "json", "-o", str(source)]) == 1
    assert source.read_bytes() == RELIEF.read_bytes()


def test_a_fifo_is_written_through(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    code, err = _compile_to(fifo, capsys)  # nothing reads it: refused at once, no hang
    assert code == 1 and "E105" in err and "FIFO" in err
    reader = subprocess.Popen(["cat", str(fifo)], stdout=subprocess.PIPE)
    time.sleep(0.3)
    assert _compile_to(fifo, capsys)[0] == 0
    out, _ = reader.communicate(timeout=30)
    assert out.startswith(b"{") and stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_character_devices_are_written_through_not_replaced(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert _compile_to("/dev/null", capsys)[0] == 0
    assert stat.S_ISCHR(os.lstat("/dev/null").st_mode)
    device = tmp_path / "null"
    try:
        os.mknod(device, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    except (PermissionError, OSError):
        pytest.skip("creating a device node needs root")
    assert _compile_to(device, capsys)[0] == 0
    assert stat.S_ISCHR(os.lstat(device).st_mode)


def test_symlinks_are_followed_and_kept(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    real = tmp_path / "real.json"
    real.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(real)
    assert _compile_to(link, capsys)[0] == 0
    assert link.is_symlink() and real.read_text().startswith("{")
    dangling = tmp_path / "dangling.json"
    dangling.symlink_to(tmp_path / "nowhere" / "x.json")
    code, err = _compile_to(dangling, capsys)
    assert code == 1 and "E105" in err and "dangling" in err


def test_a_link_planted_by_another_user_in_a_shared_folder_is_refused(tmp_path: Path) -> None:
    if os.geteuid() != 0:
        pytest.skip("planting a link owned by another user needs root")
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o1777)
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    link = shared / "out.json"
    link.symlink_to(victim)
    os.lchown(link, 12345, 12345)
    shared.chmod(0o1777)
    os.chown(shared, 54321, 54321)  # neither the folder's owner nor ours
    with pytest.raises(MseError) as error:
        write_atomic(link, "x")
    assert error.value.diagnostics[0].code == "E105"
    assert victim.read_text() == "precious"


@pytest.mark.parametrize("kind", ["directory", "proc", "missing-proc-folder", "socket"])
def test_impossible_targets_are_e105_with_exit_1(
    kind: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    if kind == "directory":
        target = str(tmp_path)
    elif kind == "proc":
        target = "/proc/self/status"
    elif kind == "missing-proc-folder":
        target = "/proc/mse-no-such-folder/x.json"
    else:
        import socket

        target = str(tmp_path / "s")
        server = socket.socket(socket.AF_UNIX)
        server.bind(target)
    code, err = _compile_to(target, capsys)
    assert code == 1
    assert err.strip().startswith(target) and " E105 " in err, err
    assert "Traceback" not in err
    _no_temporaries(tmp_path)


def test_a_read_only_folder_is_e105(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    if os.geteuid() == 0:
        # root writes into read-only folders (CI runs as root): the kernel's refusal is simulated
        import errno
        import tempfile

        def refuse(*_args: object, **kwargs: object) -> tuple[int, str]:
            raise PermissionError(errno.EACCES, "Permission denied", str(kwargs.get("dir", folder)))

        monkeypatch.setattr(tempfile, "mkstemp", refuse)
    code, err = _compile_to(folder / "x.json", capsys)
    assert code == 1 and "E105" in err


def test_sigterm_while_writing_leaves_no_temporary_file(tmp_path: Path) -> None:
    """The signal arrives after the temporary file exists and before the rename."""
    script = (
        "import os, signal, sys\n"
        "from mse import fileio\n"
        "fileio.install_termination_handler()\n"
        "real = os.fsync\n"
        "def fsync(fd):\n"
        "    os.kill(os.getpid(), signal.SIGTERM)\n"
        "    real(fd)\n"
        "os.fsync = fsync\n"
        "try:\n"
        "    fileio.write_atomic(sys.argv[1], 'data')\n"
        "except fileio.Terminated:\n"
        "    print('terminated')\n"
    )
    target = tmp_path / "out.json"
    done = subprocess.run([sys.executable, "-c", script, str(target)], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == "terminated", done.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_sigterm_of_the_command_line_exits_143_without_temporaries(tmp_path: Path) -> None:
    out = tmp_path / "many.jsonl"
    command = [sys.executable, "-m", "mse", "sample", "relief", "--count", "200000", "--format", "jsonl"]
    process = subprocess.Popen([*command, "-o", str(out)], stderr=subprocess.PIPE, cwd=tmp_path)
    time.sleep(3)
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 143 and b"Traceback" not in err
    assert not out.exists()
    _no_temporaries(tmp_path)


def test_staged_folder_writes_everything_or_nothing(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with pytest.raises(RuntimeError), staged_folder(out) as staging:
        (staging / "a.bvh").write_text("a")
        raise RuntimeError("generation failed")
    assert not out.exists()
    _no_temporaries(tmp_path)
    assert list(tmp_path.iterdir()) == []
    out.mkdir()
    (out / "keep.txt").write_text("kept")
    with staged_folder(out) as staging:
        (staging / "sub").mkdir()
        (staging / "sub" / "b.bvh").write_text("b")
    assert (out / "keep.txt").read_text() == "kept" and (out / "sub" / "b.bvh").read_text() == "b"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


UNKNOWN_ACTION = b"""<expression name="anger"><signals>
<signal id="bow" modality="torso" min_duration="1" max_duration="2"><motion action="bow"/></signal>
<signal id="jig" modality="torso" min_duration="1" max_duration="2"><motion action="jig"/></signal>
</signals><constraints><constraint>exists(bow) and exists(jig)</constraint></constraints></expression>"""


def test_animate_with_an_unknown_action_writes_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Item 13: `sample --animate` left anim/*.bvh and no timeline.json."""
    source = tmp_path / "set.xml"
    source.write_bytes(UNKNOWN_ACTION)
    anim = tmp_path / "anim"
    code = main(["sample", str(source), "--duration", "6", "--seed", "1", "--animate", str(anim), "-o", "t.json"])
    assert code == 1 and "E213" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["set.xml"]


def test_lint_flags_unknown_actions_lone_max_occurrences_and_unused_exclusive_modalities(tmp_path: Path) -> None:
    from mse.api import lint

    source = tmp_path / "set.xml"
    source.write_bytes(
        UNKNOWN_ACTION.replace(b"<signals>", b'<modality name="gaze" exclusive="true"/><signals>').replace(
            b'max_duration="2"><motion action="bow"/>', b'max_duration="2" max_occurrences="3"><motion action="bow"/>'
        )
    )
    codes = [d.code for d in lint([source])]
    assert {"W310", "W311", "W312"} <= set(codes), codes
    repetitive = source.read_bytes().replace(b'max_occurrences="3"', b'max_occurrences="3" repetitivity="1"')
    source.write_bytes(repetitive)
    assert "W311" not in [d.code for d in lint([source])]


def test_writers_that_need_a_path_use_the_same_rules(tmp_path: Path) -> None:
    """atomic_path: the video encoder's way in (a temporary file it can open by name)."""
    from mse.fileio import atomic_path

    target = tmp_path / "clip.mp4"
    target.write_bytes(b"old")
    target.chmod(0o640)
    with pytest.raises(RuntimeError), atomic_path(target, suffix=".mp4") as temporary:
        temporary.write_bytes(b"half")
        raise RuntimeError("encoder failed")
    assert target.read_bytes() == b"old" and sorted(p.name for p in tmp_path.iterdir()) == ["clip.mp4"]
    with atomic_path(target, suffix=".mp4") as temporary:
        temporary.write_bytes(b"new")
    assert target.read_bytes() == b"new" and stat.S_IMODE(target.stat().st_mode) == 0o640
    with atomic_path("/dev/null") as temporary:
        temporary.write_bytes(b"discarded")
    assert stat.S_ISCHR(os.lstat("/dev/null").st_mode)
