"""The built wheel carries the grammar and the behaviour sets, and works outside the
checkout: `mse compile embarrassment` by bundled name from a fresh virtual environment."""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    pytest.importorskip("hatchling", reason="hatchling (a dev dependency) builds the wheel")
    out = tmp_path_factory.mktemp("dist")
    subprocess.run(
        [sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", str(out), str(ROOT)],
        check=True,
        capture_output=True,
    )
    (built,) = out.glob("mse-*.whl")
    return built


def test_wheel_contains_package_data(wheel: Path) -> None:
    names = set(zipfile.ZipFile(wheel).namelist())
    assert "mse/grammar/constraints.lark" in names
    assert "mse/grammar/mse.xsd" in names
    assert "mse/behaviour_sets/embarrassment.xml" in names
    assert "mse/export/realizer_tables/greta.toml" in names
    assert len([n for n in names if n.startswith("mse/behaviour_sets/") and n.endswith(".xml")]) == 8


def test_wheel_keeps_the_optional_parts_optional(wheel: Path) -> None:
    """pip install mse: compile, lint, sample, export; [motion], [video], [learn] bring the rest."""
    from email.parser import Parser

    from mse.extras import EXTRAS

    with zipfile.ZipFile(wheel) as archive:
        (name,) = [n for n in archive.namelist() if n.endswith(".dist-info/METADATA")]
        fields = Parser().parsestr(archive.read(name).decode("utf-8"))
    assert set(EXTRAS) <= set(fields.get_all("Provides-Extra") or [])
    unconditional = {r.split(">")[0].split("[")[0].strip().lower() for r in fields.get_all("Requires-Dist") or []
                     if "extra ==" not in r}
    assert unconditional == {"lxml", "lark", "numpy", "ortools", "python-constraint2", "tqdm"}


@pytest.mark.slow
def test_wheel_installs_and_runs_in_a_fresh_venv(wheel: Path, tmp_path: Path) -> None:
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    python = venv / "bin" / "python"
    subprocess.run([str(python), "-m", "pip", "install", "-q", "--no-deps", str(wheel)], check=True)
    # The dependencies come from this environment's site-packages (no network needed);
    # .pth files there are not processed, so the editable checkout stays invisible.
    env = {**os.environ, "PYTHONPATH": sysconfig.get_paths()["purelib"]}
    env.pop("MSE_SHARED", None)
    run = {"cwd": tmp_path, "env": env, "capture_output": True, "text": True}
    where = subprocess.run([str(python), "-c", "import mse; print(mse.__file__)"], check=True, **run)  # type: ignore[call-overload]
    assert str(venv) in where.stdout, where.stdout
    compiled = subprocess.run([str(venv / "bin" / "mse"), "compile", "embarrassment"], **run)  # type: ignore[call-overload]
    assert compiled.returncode == 0, compiled.stderr
    assert '"name": "embarrassment"' in compiled.stdout
    listed = subprocess.run([str(python), "-m", "mse", "list"], **run)  # type: ignore[call-overload]
    assert listed.returncode == 0 and "relief" in listed.stdout, listed.stderr
