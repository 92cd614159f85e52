"""Renderers of diagnostics for ``mse lint``: text, json, github annotations, SARIF 2.1.0."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence

from mse import __version__
from mse.diagnostics import CODES, Diagnostic, Span


def as_text(diagnostics: Sequence[Diagnostic]) -> str:
    return "".join(d.render() + "\n" for d in diagnostics)


def as_json(diagnostics: Sequence[Diagnostic]) -> str:
    records = [
        {
            "path": d.span.path,
            "line": d.span.line,
            "col": d.span.col,
            "code": d.code,
            "severity": d.severity.value,
            "message": d.message,
        }
        for d in diagnostics
    ]
    return json.dumps(records, indent=2) + "\n"


def _escape_github(text: str, *, property_value: bool = False) -> str:
    text = text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")
    if property_value:
        text = text.replace(":", "%3A").replace(",", "%2C")
    return text


def as_github(diagnostics: Sequence[Diagnostic]) -> str:
    lines = []
    for d in diagnostics:
        level = {"error": "error", "warning": "warning", "note": "notice"}[d.severity.value]
        props = f"file={_escape_github(d.span.path, property_value=True)}"
        if d.span.line > 0:
            props += f",line={d.span.line},col={max(d.span.col, 1)}"
        props += f",title={_escape_github(d.code, property_value=True)}"
        lines.append(f"::{level} {props}::{_escape_github(f'{d.code} {d.message}')}\n")
    return "".join(lines)


def _information_uri() -> dict[str, str]:
    """``informationUri`` of the SARIF driver: the documentation URL the installed package
    declares ([project.urls] in pyproject.toml, preferring Documentation, then Homepage or
    Repository). SARIF makes the field optional, so without a declared URL it is left out
    rather than filled with a placeholder."""
    from importlib import metadata

    try:
        declared = metadata.metadata("mse").get_all("Project-URL") or []
    except metadata.PackageNotFoundError:
        return {}
    urls = {}
    for entry in declared:
        label, _, url = entry.partition(",")
        urls[label.strip().lower()] = url.strip()
    for label in ("documentation", "homepage", "repository", "source"):
        if urls.get(label, "").startswith("https://"):
            return {"informationUri": urls[label]}
    return {}


def as_sarif(diagnostics: Sequence[Diagnostic]) -> str:
    used = sorted({d.code for d in diagnostics})
    rules = [
        {
            "id": code,
            "shortDescription": {"text": CODES.get(code, code)},
            "defaultConfiguration": {"level": Diagnostic(code, "", Span("")).severity.value},
        }
        for code in used
    ]
    results = []
    for d in diagnostics:
        location: dict[str, object] = {"artifactLocation": {"uri": d.span.path}}
        if d.span.line > 0:
            location["region"] = {"startLine": d.span.line, "startColumn": max(d.span.col, 1)}
        results.append(
            {
                "ruleId": d.code,
                "ruleIndex": used.index(d.code),
                "level": d.severity.value,
                "message": {"text": d.message},
                "locations": [{"physicalLocation": location}],
            }
        )
    log = {
        "$schema": "https://json.schemastore.org/sarif-2.1.0.json",
        "version": "2.1.0",
        "runs": [
            {
                "tool": {
                    "driver": {
                        "name": "mse",
                        "version": __version__,
                        **_information_uri(),
                        "rules": rules,
                    }
                },
                "results": results,
            }
        ],
    }
    return json.dumps(log, indent=2) + "\n"


FORMATTERS: dict[str, Callable[[Sequence[Diagnostic]], str]] = {
    "text": as_text,
    "json": as_json,
    "github": as_github,
    "sarif": as_sarif,
}
