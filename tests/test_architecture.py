"""Data flows one way inside mse/, and heavy libraries load only where they are needed."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "mse"

# Lower number = lower layer.  A module may import its own layer and the ones below.
LAYERS: dict[str, int] = {
    "mse.diagnostics": 0,
    "mse.resources": 0,
    "mse.fileio": 0,
    "mse.input_files": 0,
    "mse.limits": 0,
    "mse.progress": 0,
    "mse.extras": 0,
    "mse.syntax": 1,
    "mse.ir": 2,
    "mse.solve": 3,
    "mse.timeline": 4,
    "mse.envelope": 4,
    "mse.export": 5,
    "mse.motion": 5,
    "mse.learn": 5,
    "mse.repairing": 5,
    "mse.api": 6,
    "mse.sampling": 6,
    "mse.model_cache": 6,
    "mse.dialogue": 6,
    "mse.serve": 6,
    "mse.study": 6,
    "mse.cli": 7,
    "mse.__main__": 7,
}
HEAVY = ("ortools", "hmmlearn", "scipy", "sklearn", "matplotlib", "statsmodels", "selenium", "constraint", "av",
         "aggdraw", "PIL")


def _layer(module: str) -> int | None:
    for prefix, layer in sorted(LAYERS.items(), key=lambda item: -len(item[0])):
        if module == prefix or module.startswith(prefix + "."):
            return layer
    return None


def _modules() -> list[tuple[str, Path]]:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        found.append((".".join(parts), path))
    return found


def _imports(path: Path) -> list[tuple[str, int, bool]]:
    """(imported module, line, at module top level)"""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    top_level = {id(node) for node in tree.body}
    for node in tree.body:  # imports guarded by `if TYPE_CHECKING:` are not run
        if isinstance(node, ast.If):
            top_level.update(id(child) for child in node.body)
    result = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            result += [(alias.name, node.lineno, id(node) in top_level) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            result.append((node.module, node.lineno, id(node) in top_level))
    return result


@pytest.mark.slow
def test_lower_layers_never_import_higher_ones() -> None:
    problems = []
    for module, path in _modules():
        own = _layer(module)
        if own is None or module == "mse":
            continue
        for imported, line, _ in _imports(path):
            other = _layer(imported)
            if other is not None and other > own:
                problems.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {module} imports {imported}")
    assert not problems, "\n".join(problems)


def test_motion_does_not_import_export() -> None:
    for module, path in _modules():
        if module.startswith("mse.motion"):
            assert not any(name.startswith("mse.export") for name, _, _ in _imports(path)), module


@pytest.mark.parametrize(
    "argv",
    [
        ["compile", "embarrassment"],
        ["lint", "--no-deep", "behaviour_sets"],
        ["sample", "embarrassment", "--duration", "10", "--seed", "1", "--format", "json"],
        ["list"],
    ],
)
def test_cli_paths_do_not_load_heavy_libraries(argv: list[str]) -> None:
    script = (
        "import sys, io, contextlib\n"
        "from mse.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        f"    code = main({argv!r})\n"
        f"heavy = sorted(m for m in sys.modules if m.split('.')[0] in {HEAVY!r})\n"
        "print(code, heavy)\n"
    )
    root = PACKAGE.parent
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=root, check=True)
    assert out.stdout.strip().endswith("[]"), out.stdout + out.stderr
    assert out.stdout.startswith("0 "), out.stdout + out.stderr


@pytest.mark.slow
def test_no_import_cycles() -> None:
    """Imports run one way: no module reaches itself again through mse imports (lazy ones too)."""
    names = {module for module, _ in _modules()}
    graph: dict[str, set[str]] = {}
    for module, path in _modules():
        edges = set()
        for imported, _, _ in _imports(path):
            # "from mse.a import b" may name the submodule mse.a.b or an attribute of mse.a
            target = imported if imported in names else None
            if target and target != module and not module.startswith(target + "."):
                edges.add(target)
        graph[module] = edges
    state: dict[str, int] = {}
    cycles: list[str] = []

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                cycles.append(" -> ".join([*stack[stack.index(nxt):], nxt]))
            elif nxt not in state:
                visit(nxt, [*stack, nxt])
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
    assert not cycles, "\n".join(cycles)


def test_solver_backends_do_not_import_each_other() -> None:
    backends = ("greedy", "cpsat", "csp")
    problems = []
    for module, path in _modules():
        own = next((b for b in backends if module.startswith(f"mse.solve.{b}")), None)
        if own is None:
            continue
        for imported, line, _ in _imports(path):
            other = next((b for b in backends if imported.startswith(f"mse.solve.{b}")), None)
            if other is not None and other != own:
                problems.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {module} imports {imported}")
    assert not problems, "\n".join(problems)


def test_motion_methods_do_not_import_each_other() -> None:
    """The two motion methods sit side by side over mse.motion.base; the base imports neither."""
    methods = ("lma_hmm", "hsmm")
    problems = []
    for module, path in _modules():
        if not module.startswith("mse.motion."):
            continue
        part = module.split(".")[2]
        for imported, line, _ in _imports(path):
            if not imported.startswith("mse.motion."):
                continue
            other = imported.split(".")[2]
            if (part in methods and other in methods and other != part) or (part == "base" and other != "base"):
                problems.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {module} imports {imported}")
    assert not problems, "\n".join(problems)
