"""Readable terminal view of a timeline: one lane per modality under a time ruler."""

from __future__ import annotations

import math

from mse.timeline import Timeline

WIDTH = 60


def _ruler(duration: float, width: int) -> tuple[str, str]:
    step = max(1, math.ceil(duration / 10))
    ticks = [" "] * (width + 1)
    labels = [" "] * (width + 8)
    second = 0
    while second <= duration + 1e-9:
        column = round(second / duration * width)
        ticks[column] = "|"
        text = f"{second}"
        for offset, char in enumerate(text):
            if column + offset < len(labels):
                labels[column + offset] = char
        second += step
    return "".join(labels).rstrip(), "".join(ticks)


def render_table(timeline: Timeline, *, width: int = WIDTH) -> str:
    duration = timeline.duration or 1.0
    scale = width / duration
    lanes: dict[str, list[str]] = {}
    for signal in timeline.signals:
        lanes.setdefault(signal.modality or "?", [])
    name_width = max([len(m) for m in lanes] + [8])
    lines = [
        f"{timeline.expression}  duration {timeline.duration:g} s  solver {timeline.solver}  seed {timeline.seed}"
        + "".join(f"  {key} {timeline.extra[key]}" for key in ("mode", "method") if key in timeline.extra),
    ]
    labels, ticks = _ruler(duration, width)
    lines.append(" " * (name_width + 2) + labels)
    lines.append(" " * (name_width + 2) + ticks)
    for modality in lanes:
        # A bar writes its whole id (then '=' up to its end) and keeps one blank column
        # after it; a bar that would touch the previous one in a row goes to the next row.
        rows: list[list[str]] = []
        for signal in (s for s in timeline.signals if (s.modality or "?") == modality):
            first = min(width - 1, int(signal.start * scale))
            last = max(first + 1, min(width, round(signal.stop * scale)))
            text = signal.id.ljust(last - first, "=")
            end = first + len(text)
            row = next((r for r in rows if all(c == " " for c in r[max(0, first - 1) : end + 1])), None)
            if row is None:
                row = [" "] * width
                rows.append(row)
            if len(row) < end + 1:
                row.extend(" " * (end + 1 - len(row)))
            row[first:end] = list(text)
        for index, row in enumerate(rows or [[" "] * width]):
            name = modality if index == 0 else ""
            lines.append(f"{name:>{name_width}}  " + "".join(row).rstrip())
    lines.append("")
    for signal in timeline.signals:
        times = f"{signal.start:7.3f} - {signal.stop:7.3f}"
        lines.append(f"  {times}  {signal.modality:<{name_width}} {signal.id}  ({signal.lexeme})")
    return "\n".join(lines) + "\n"
