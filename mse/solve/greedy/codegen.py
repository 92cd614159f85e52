"""Constraint checks compiled to one flat Python function each (docs/sampler.md, "Speed").

:func:`mse.solve.greedy.closures.compile_expr` builds a tree of closures: one call per node of
the expression per check, and the walk makes tens of thousands of checks per second.  Here a
whole constraint becomes the source of one function, made once per plan with ``exec``: every
signal's boxes are fetched once, every atom's usual case (one occurrence of each signal) is
inlined, and the connectives are lookups in the same tables.  The rarer cases (a signal with
several occurrences, an atom naming one signal twice, comparisons) call the closure of that
atom, so every atom yields exactly the mask :func:`compile_expr` gives: the same verdicts, the
same walk, the same outputs (tests/test_greedy_codegen.py compares the two).

The generated source only ever contains signal ids as ``repr`` string literals, integers and
names of this module's namespace.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from mse.ir import model as ir
from mse.solve.greedy.masks import F, N, T, relation_mask_source

#: nesting of generated brackets after which a value goes through a local (Python allows 200)
SPILL_DEPTH = 32


class _Writer:
    """The body of one generated function: statements computing the atoms' masks into
    locals, then one expression combining them."""

    def __init__(self, compile_atom: Callable[[ir.Expr], Callable[[Any], int]]) -> None:
        self.compile_atom = compile_atom
        self.loads: dict[str, str] = {}  # signal id -> local holding its boxes
        self.statements: list[str] = []
        self.namespace: dict[str, object] = {}

    def boxes(self, signal: str) -> str:
        local = self.loads.get(signal)
        if local is None:
            local = self.loads[signal] = f"s{len(self.loads)}"
        return local

    def fallback(self, atom: ir.Expr) -> str:
        """A local holding the mask of ``atom`` computed by its closure."""
        name = f"atom{len(self.namespace)}"
        self.namespace[name] = self.compile_atom(atom)
        local = f"m{len(self.statements)}"
        self.statements.append(f"{local} = {name}(env)")
        return local

    def spill(self, source: str) -> str:
        """A local holding the value of ``source``: keeps the generated expressions shallow."""
        local = f"v{len(self.statements)}"
        self.statements.append(f"{local} = {source}")
        return local

    def expression(self, expr: ir.Expr, depth: int = 0) -> str:
        """Source of an expression for the mask of ``expr`` (statements added as needed).

        Python's parser refuses more than 200 nested brackets ("too many nested
        parentheses"), and constraints may nest up to ``limits`` allow with ``and`` chains of
        any length: every ``SPILL_DEPTH`` levels, and every fold over many operands, goes
        through a local instead of nesting further."""
        source = self._expression(expr, depth)
        if depth % SPILL_DEPTH == SPILL_DEPTH - 1:
            return self.spill(source)
        return source

    def _expression(self, expr: ir.Expr, depth: int) -> str:
        if isinstance(expr, ir.Exists):
            return f"({T} if {self.boxes(expr.signal)} else {F})"
        if isinstance(expr, ir.Relation):
            if expr.left == expr.right:
                return self.fallback(expr)
            left, right = self.boxes(expr.left), self.boxes(expr.right)
            local = self.fallback(expr)  # the general case; the usual one is written out below
            general = self.statements.pop()
            self.statements.append(
                f"if not {left} or not {right}:\n"
                f"        {local} = {N}\n"
                f"    elif len({left}) == 1 and len({right}) == 1:\n"
                f"        a = {left}[0]\n"
                f"        b = {right}[0]\n"
                f"        {local} = {relation_mask_source(expr.kind)}\n"
                f"    else:\n"
                f"        {general}"
            )
            return local
        if isinstance(expr, ir.Compare):
            return self.fallback(expr)
        if isinstance(expr, ir.Not):
            return f"NOT[{self.expression(expr.operand, depth + 1)}]"
        if isinstance(expr, ir.Implies):
            left_mask = self.expression(expr.left, depth + 1)
            return f"IMPLIES[{left_mask} << 3 | {self.expression(expr.right, depth + 1)}]"
        table = "AND" if isinstance(expr, ir.And) else "OR"
        parts = [self.expression(e, depth + 1) for e in ir.children(expr)]
        if len(parts) == 1:
            return f"({table}_MANY(({parts[0]},)))"
        # Folded over the binary table: the same mask as partial.mask_and / mask_or of all the
        # operands (tests/test_greedy_codegen.py checks every combination up to five).
        folded = parts[0]
        for index, part in enumerate(parts[1:], start=1):
            folded = f"{table}[{folded} << 3 | {part}]"
            if index % SPILL_DEPTH == 0:
                folded = self.spill(folded)
        return folded


def generate(
    expr: ir.Expr,
    triggers: Sequence[str] | None,
    compile_atom: Callable[[ir.Expr], Callable[[Any], int]],
    tables: Mapping[str, object],
) -> Callable[[Any], Any]:
    """One function of the environment: with ``triggers`` None, the mask of ``expr``
    (``compile_expr``); otherwise ``CompiledConstraint.acceptable`` (true when no trigger
    occurs, else the mask and ``T | N``, only used for its truth)."""
    writer = _Writer(compile_atom)
    result = writer.expression(expr)
    guard: list[str] = []
    if triggers is not None:
        result = f"({result}) & {T | N}"
    if triggers:
        names = [writer.boxes(t) for t in triggers]
        guard = [f"if not ({' or '.join(names)}):\n        return True"]
    loads = [f"{local} = get({signal!r})" for signal, local in writer.loads.items()]
    body = ["get = env.get", *loads, *guard, *writer.statements, f"return {result}"]
    source = "def check(env):\n" + "".join(f"    {line}\n" for line in body)
    namespace: dict[str, Any] = {**tables, **writer.namespace}
    exec(compile(source, "<mse.solve.greedy.codegen>", "exec"), namespace)
    check: Callable[[Any], Any] = namespace["check"]
    return check
