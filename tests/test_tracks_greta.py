"""OpenFace 2.0 CSV tracks through Greta's own OpenFace readers (``$MSE_SHARED/realizers/greta/openface``):
every row read, nothing dropped, and the values Greta parses equal ours, frame by frame.

Greta's reader is run as a reconnection (``--reconnect``): in a fresh Greta session its
``OpenFaceFrame`` throws on the first frame of any file in OpenFace 2.0's own column set (17
``AU_r`` against 18 ``AU_c`` columns; ``$MSE_SHARED/realizers/README.md``), ours and OpenFace's alike.
"""

from __future__ import annotations

import json
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import mse.api
from mse.export.tracks.model import sample
from mse.export.tracks.openface import openface_values, write_openface
from mse.resources import bundled_names
from mse.sampling import sample as sample_timeline
from mse.timeline import Timeline
from tests.realizer_harness import java_missing_reason


@dataclass
class GretaRead:
    """What Greta's OpenFace 2.0 CSV reader made of one file."""

    rows: list[dict[str, Any]]  # one JSON line per data row
    summary: dict[str, Any]

    @property
    def rejected(self) -> int:
        """Rows Greta dropped or never read (0 for a file it plays whole)."""
        return (
            int(self.summary["rows_dropped"])
            + (len(self.rows) - int(self.summary["rows_kept"]))
            + int(bool(self.summary.get("reader_died")))
        )


def read_with_greta(shared: Path, csv: Path) -> GretaRead:
    """Run Greta's ``OpenFaceOutputStreamCSVReader`` (a reconnection, see the module docstring) on ``csv``."""
    done = subprocess.run(
        [str(shared / "realizers" / "greta" / "openface"), "--reconnect", str(csv)],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    lines = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    rows = [line for line in lines if "row" in line and "event" not in line]
    summary = next(line for line in lines if line.get("event") == "summary")
    return GretaRead(rows, summary)


def greta_differences(timeline: Timeline, shared: Path, folder: Path) -> tuple[GretaRead, list[str]]:
    """Write ``timeline``'s OpenFace CSV, read it with Greta, and list every value Greta parsed
    that differs from ours (empty: every frame read as written)."""
    tracks = sample(timeline)
    csv = folder / f"{timeline.expression}-{timeline.seed}.openface.csv"
    csv.write_text(write_openface(tracks), encoding="utf-8")
    read = read_with_greta(shared, csv)
    ours = openface_values(tracks)
    problems: list[str] = []
    if len(read.rows) != tracks.frame_count:
        problems.append(f"{len(read.rows)} rows read, {tracks.frame_count} written")
    for k, row in enumerate(read.rows):
        if row.get("csv_reader") != "kept":
            problems.append(f"row {k}: {row.get('csv_reader')}")
            continue
        parsed = row["parsed"]
        theirs: dict[str, float] = {"timestamp": parsed["timestamp"]}
        for eye in (0, 1):
            theirs.update({f"gaze_{eye}_{a}": v for a, v in zip("xyz", parsed[f"gaze_{eye}"], strict=True)})
        theirs.update(dict(zip(("gaze_angle_x", "gaze_angle_y"), parsed["gaze_angle"], strict=True)))
        theirs.update(dict(zip(("pose_Rx", "pose_Ry", "pose_Rz"), parsed["pose_R"], strict=True)))
        theirs.update({name: 5.0 * v for name, v in parsed["au_r_div5"].items()})
        theirs.update(parsed["au_c"])
        if parsed["frame"] != k + 1 or parsed["success"] is not True:
            problems.append(f"row {k}: frame {parsed['frame']}, success {parsed['success']}")
        for name, values in ours.items():
            tolerance = 5e-7 if name.startswith("gaze_0") or name.startswith("gaze_1") else 5e-4
            if name.endswith("_r"):
                tolerance = 5e-3
            if abs(theirs[name] - float(values[k])) > tolerance + 1e-9:
                problems.append(f"row {k}: {name} Greta {theirs[name]} ours {float(values[k])}")
    return read, problems


@pytest.fixture(scope="module")
def shared_with_java(shared_dir: Path) -> Path:
    reason = java_missing_reason(shared_dir)
    if reason is not None or not (shared_dir / "realizers" / "greta" / "openface").exists():
        pytest.skip(reason or "Greta's OpenFace reader not found")
    return shared_dir


@pytest.mark.slow
@pytest.mark.parametrize("name", bundled_names())
def test_greta_reads_every_frame_of_every_bundled_set(name: str, shared_with_java: Path, tmp_path: Path) -> None:
    for seed in (1, 2):
        timeline = sample_timeline(mse.api.load(name, cache=True), 10.0, seed=seed)
        read, problems = greta_differences(timeline, shared_with_java, tmp_path)
        assert read.rejected == 0 and problems == [], problems[:5]
        assert read.summary["frames_sent"] > 0


@pytest.mark.slow
def test_greta_reads_imported_greta_sets(shared_with_java: Path, tmp_path: Path) -> None:
    from mse.syntax.greta import import_greta

    greta = shared_with_java / "greta"
    expressions = import_greta(greta / "lexicon.xml", greta / "constraint.xml")
    for expression in expressions[:3]:
        model = mse.api.loads(expression.xml, path=f"{expression.name}.xml")
        timeline = sample_timeline(model, 10.0, seed=1)
        read, problems = greta_differences(timeline, shared_with_java, tmp_path)
        assert read.rejected == 0 and problems == [], problems[:5]


def test_greta_plays_a_smile_at_its_intensity(shared_with_java: Path, tmp_path: Path) -> None:
    """What Greta sends to its face: 0.4 x AU_r / 5 x AU_c, smoothed (its reader's own scale)."""
    timeline = Timeline("smile", 3.0, (mse.TimelineSignal("s", "face", "faceexp=smile", 0.5, 2.5),), seed=0)
    read, problems = greta_differences(timeline, shared_with_java, tmp_path)
    assert problems == []
    sent = [row for row in read.rows if row.get("sent") and 1.2 <= row["greta_time"] <= 1.8]
    assert sent and all(np.isclose(row["au_frame"]["aus"]["AU12"], 0.4, atol=1e-3) for row in sent)
