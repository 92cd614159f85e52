"""ELAN out: EAF 3.0 files read back by pympi-ling (an independent reader) and by mse learn."""

from __future__ import annotations

from pathlib import Path

import pytest
from lxml import etree

import mse.api as api
import mse.sampling as sampling
from mse.cli import main
from mse.export import render
from mse.learn.read_eaf import read_eaf
from mse.timeline import Timeline

pympi = pytest.importorskip("pympi")


def _timeline(seed: int = 5) -> Timeline:
    result = sampling.sample(api.load("embarrassment"), 10.0, seed=seed)
    assert isinstance(result, Timeline)
    return result


def test_eaf_structure_is_elan_3_0(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    text = render(_timeline(), "eaf")
    root = etree.fromstring(text.encode("utf-8"))
    assert root.tag == "ANNOTATION_DOCUMENT"
    assert root.get("VERSION") == "3.0" and root.get("FORMAT") == "3.0"
    assert root.get("DATE") == "2023-11-14T22:13:20+00:00"
    order = [child.tag for child in root]
    first_of = {tag: order.index(tag) for tag in set(order)}
    assert first_of["HEADER"] < first_of["TIME_ORDER"] < first_of["TIER"] < first_of["LINGUISTIC_TYPE"] \
        < first_of["CONSTRAINT"]
    assert root.find("HEADER").get("TIME_UNITS") == "milliseconds"  # type: ignore[union-attr]
    values = [int(slot.get("TIME_VALUE")) for slot in root.iter("TIME_SLOT")]  # type: ignore[arg-type]
    assert values == sorted(values) and len(values) == len(set(values))
    for tier in root.iter("TIER"):
        assert tier.get("LINGUISTIC_TYPE_REF") == "mse-signal"


def test_pympi_reads_every_signal_back(tmp_path: Path) -> None:
    timeline = _timeline()
    target = tmp_path / "t.eaf"
    target.write_text(render(timeline, "eaf"), encoding="utf-8")
    eaf = pympi.Elan.Eaf(str(target))
    expected = sorted((s.modality, round(s.start * 1000), round(s.stop * 1000), s.id) for s in timeline.signals)
    found = sorted((tier, a[0], a[1], a[2]) for tier in eaf.get_tier_names()
                   for a in eaf.get_annotation_data_for_tier(tier))
    assert found == expected
    assert set(eaf.get_tier_names()) == {s.modality for s in timeline.signals}


def test_mse_reads_its_eaf_back_with_the_duration(tmp_path: Path) -> None:
    timeline = _timeline(7)
    target = tmp_path / "t.eaf"
    target.write_text(render(timeline, "eaf"), encoding="utf-8")
    sequence, problems = read_eaf(target)
    assert sequence is not None and not problems
    assert sequence.duration == 10000
    assert sorted((a.label, a.start, a.stop) for a in sequence.annotations) == sorted(
        (s.id, round(s.start * 1000), round(s.stop * 1000)) for s in timeline.signals)


def test_sample_count_writes_one_eaf_per_timeline(tmp_path: Path) -> None:
    folder = tmp_path / "generated"
    assert main(["sample", "relief", "--count", "5", "--seed", "2", "--format", "eaf", "-o", f"{folder}/"]) == 0
    files = sorted(folder.glob("*.eaf"))
    assert [f.name for f in files] == [f"relief-{n}.eaf" for n in (1, 2, 3, 4, 5)]
    for file in files:
        assert pympi.Elan.Eaf(str(file)).get_tier_names()


def test_export_command_writes_eaf(tmp_path: Path) -> None:
    source = tmp_path / "t.json"
    source.write_text(_timeline().dumps(), encoding="utf-8")
    target = tmp_path / "t.eaf"
    assert main(["export", str(source), "--format", "eaf", "-o", str(target)]) == 0
    assert pympi.Elan.Eaf(str(target)).get_tier_names()


def test_sample_count_without_a_folder_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sample", "relief", "--count", "2", "--format", "eaf", "-o", str(tmp_path / "x.eaf")]) == 1
    assert "FOLDER" in capsys.readouterr().err
