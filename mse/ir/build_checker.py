"""The checker build.py reports through: every semantic problem (E2xx) of one file is collected
(not raised), and numbers, seconds and ticks are read with their range checks."""

from __future__ import annotations

import math

from mse.diagnostics import Diagnostic, Span
from mse.ir.schedule import to_ticks
from mse.limits import parse_double, parse_integer, time_problem
from mse.syntax import ast


class BuildChecker:
    """The E2xx diagnostics of one file, collected while it is built, and the checked reading
    of its numbers, seconds and ticks."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.diagnostics: list[Diagnostic] = []

    def error(self, code: str, message: str, span: Span) -> None:
        self.diagnostics.append(Diagnostic(code, message, span))

    def number(
        self,
        attributes: dict[str, ast.Attribute],
        key: str,
        default: float,
        *,
        minimum: float | None = None,
        maximum: float | None = None,
        code: str = "E204",
    ) -> float:
        attribute = attributes.get(key)
        if attribute is None:
            return default
        parsed = parse_double(attribute.value)
        if parsed is None:
            special = attribute.value.strip().lower().lstrip("+-") in ("nan", "inf", "infinity")
            reason = "must be a finite number" if special else "is not a number"
            self.error("E204", f"{key}={attribute.value[:60]!r} {reason}", attribute.span)
            return default
        value = parsed
        if not math.isfinite(value):
            self.error("E204", f"{key}={attribute.value[:60]!r} must be a finite number", attribute.span)
            return default
        if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
            bounds = f"in [{minimum:g}, {maximum:g}]" if maximum is not None else f">= {minimum:g}"
            self.error(code, f"{key}={attribute.value[:60]} must be {bounds}", attribute.span)
            return default
        return value

    def seconds(self, attributes: dict[str, ast.Attribute], key: str, default: float) -> float:
        """A duration attribute: a number in [0, MAX_SECONDS] (E204, E215)."""
        value = self.number(attributes, key, default, minimum=0.0)
        attribute = attributes.get(key)
        problem = time_problem(value, minimum=0.0) if attribute is not None and math.isfinite(value) else None
        if attribute is not None and problem is not None:
            self.error("E215", f"{key}={attribute.value[:60]} {problem}", attribute.span)
            return default
        return value

    def ticks(self, seconds: float, span: Span, what: str) -> int:
        """``seconds`` on the 1 ms grid, with a W309 warning when that rounds it."""
        ticks = to_ticks(seconds)
        if abs(seconds * 1000 - ticks) > 1e-6:
            self.error("W309", f"{what} {seconds:g} s is finer than the 1 ms grid of the semantics: "
                       f"it is rounded to {ticks / 1000:g} s", span)
        return ticks

    def integer(self, attributes: dict[str, ast.Attribute], key: str, default: int, *, minimum: int, code: str) -> int:
        attribute = attributes.get(key)
        if attribute is None:
            return default
        value = parse_integer(attribute.value)
        if value is None or value < minimum:
            self.error(
                code,
                f"{key}={attribute.value[:60]!r} must be a whole number >= {minimum} (at most 9 digits)",
                attribute.span,
            )
            return default
        return value
