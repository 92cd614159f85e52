"""The optional parts (mse/extras.py, pyproject.toml [project.optional-dependencies]): without
them compile, check, lint, sample and the text exports work; a command that needs one says
which extra to install (exit 1, no traceback); every import of their packages is guarded."""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
import tomllib
from importlib import metadata
from pathlib import Path

import pytest

from mse.extras import EXTRAS

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "mse"
OPTIONAL = sorted({module for modules in EXTRAS.values() for module in modules})


def _requirement_names(requirements: list[str]) -> set[str]:
    return {re.split(r"[\[<>=!~; ]", r, maxsplit=1)[0].lower() for r in requirements}


def test_pyproject_declares_each_extra() -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    optional = project["optional-dependencies"]
    distributions = metadata.packages_distributions()
    core = _requirement_names(project["dependencies"])
    for extra, modules in EXTRAS.items():
        declared = _requirement_names(optional[extra])
        for module in modules:
            provided = {name.lower() for name in distributions[module]}
            assert provided & declared, f"[{extra}] lacks the distribution of {module}"
            assert not provided & core, f"{module} is a core dependency and in [{extra}]"
    # the README's set-up (pip install -e '.[dev]') installs every part
    (everything,) = [r for r in optional["dev"] if r.startswith("mse[")]
    assert set(everything[4:-1].split(",")) == set(EXTRAS)


def _guarded_imports(path: Path) -> list[str]:
    """Imports of an extra's package that are neither typing-only nor in ``with require(...)``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    problems: list[str] = []

    def visit(node: ast.AST, extra: str | None, typing_only: bool) -> None:
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            typing_only = True
        if isinstance(node, ast.With):
            for item in node.items:
                call = item.context_expr
                if isinstance(call, ast.Call) and ast.unparse(call.func) == "require":
                    extra = ast.literal_eval(call.args[0])
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        for name in names:
            top = name.partition(".")[0]
            if top in OPTIONAL and not typing_only and (extra is None or top not in EXTRAS[extra]):
                problems.append(f"{path.relative_to(ROOT)}:{node.lineno}: import {name}")
        for child in ast.iter_child_nodes(node):
            visit(child, extra, typing_only)

    visit(tree, None, False)
    return problems


@pytest.mark.slow
def test_every_import_of_an_optional_package_names_its_extra() -> None:
    problems = [p for path in sorted(PACKAGE.rglob("*.py")) if path.name != "extras.py" for p in _guarded_imports(path)]
    assert not problems, "\n".join(problems)


# One fresh interpreter in which the optional packages cannot be imported (as if never installed)
# runs every command through mse.cli.main and reports exit code, stdout and stderr.
_RUNNER = """
import contextlib, io, json, sys
for name in {optional!r}:
    sys.modules[name] = None  # "import name" now raises ModuleNotFoundError
from mse.cli import main
results = []
for argv in json.loads(sys.argv[1]):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    results.append([argv, code, out.getvalue(), err.getvalue()])
print(json.dumps(results))
"""


def _run_without_extras(commands: list[list[str]], cwd: Path) -> list[tuple[list[str], int, str, str]]:
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT), "MSE_CACHE_DIR": str(cwd / "cache")}
    done = subprocess.run(
        [sys.executable, "-c", _RUNNER.format(optional=OPTIONAL), json.dumps(commands)],
        capture_output=True, text=True, cwd=cwd, env=env, timeout=600,
    )
    assert done.returncode == 0, done.stderr
    return [tuple(r) for r in json.loads(done.stdout)]  # type: ignore[misc]


@pytest.mark.slow
def test_core_commands_work_without_extras_and_the_others_name_theirs(tmp_path: Path) -> None:
    from mse.motion.base.starter import starter_library
    from mse.motion.hsmm import api
    from mse.motion.hsmm.io import save_model

    library = starter_library()  # a small HSMM model, trained here with every package at hand
    clips = [(library.motion(c), c.style) for c in library.select(action="bow")][:3]
    save_model(tmp_path / "bow.avg", api.train_average(clips, "bow", api.Options(states=3)))
    anger = str(ROOT / "behaviour_sets" / "anger.xml")
    works = [
        ["compile", anger],
        ["sample", "anger", "--seed", "1", "--duration", "4", "-o", "t.json"],
        ["sample", "anger", "--seed", "1", "--solver", "cpsat", "--format", "json"],
        ["sample", str(ROOT / "tests" / "fixtures" / "valid" / "minimal.xml"), "--solver", "csp", "--duration", "4"],
        ["check", anger, "t.json"],
        ["lint", str(ROOT / "behaviour_sets"), "--format", "sarif"],
        *(["export", "t.json", "--format", fmt] for fmt in ("bml", "greta-bml", "svg", "html", "eaf")),
        ["sample", "anger", "--seed", "7", "--format", "html"],
        ["list"],
    ]
    needs = {
        "video": [
            ["render", "t.json", "-o", "t.mp4"],
            ["render", "t.json", "-o", "t.png"],
            ["export", "t.json", "--format", "gif", "-o", "t.gif"],
            ["sample", "anger", "--format", "webm", "-o", "t.webm"],
        ],
        "motion": [
            ["animate", "t.json", "-o", "motion"],
            ["sample", "embarrassment", "--seed", "1", "--animate", "motion2", "-o", "e.json"],
            ["style", "synth", "bow.avg", "-o", "bow.bvh"],
        ],
        "learn": [["learn", "t.json"]],
        "serve": [["serve", "--port", "0"]],
        "study": [["study", "analyze", str(ROOT / "tests" / "fixtures" / "study" / "results.csv"), "-o", "report"]],
    }
    results = _run_without_extras([*works, *(argv for group in needs.values() for argv in group)], tmp_path)
    for argv, code, out, err in results[: len(works)]:
        assert code == 0 and "Traceback" not in err, (argv, err)
        assert out or argv[0] in ("check",) or "-o" in argv, argv
    extra_of = {tuple(argv): extra for extra, group in needs.items() for argv in group}
    for argv, code, out, err in results[len(works):]:
        extra = extra_of[tuple(argv)]
        assert (code, out) == (1, ""), argv
        assert err.splitlines()[-1] == f"error: mse {argv[0]} needs the '{extra}' extra: pip install 'mse[{extra}]'"
    # nothing half-written by the refused commands
    assert sorted(p.name for p in tmp_path.iterdir() if p.name != "cache") == ["bow.avg", "t.json"]


@pytest.mark.slow
def test_import_and_sampling_load_no_optional_package() -> None:
    script = (
        "import sys, mse\n"
        "mse.sample(mse.load('anger'), 10.0, seed=1)\n"
        "mse.lint(['anger'])\n"
        f"print(sorted(m for m in sys.modules if m.split('.')[0] in {OPTIONAL!r}))\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT, check=True)
    assert done.stdout.strip() == "[]", done.stdout + done.stderr
