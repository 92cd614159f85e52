"""``mse study analyze`` (issue 34): the MSE paper's Tables 1 and 2 reproduced from its own numbers,
a simulated study recovered, and bad results files refused with their location."""

from __future__ import annotations

import csv
import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from mse.cli import main
from mse.study.analysis.statistics import unbiased_kappa

pytest.importorskip("statsmodels")

HEADER = ["participant", "task", "emotion", "condition", "response", "stimulus", "trial", "seconds"]
PAPER = tomllib.loads((Path(__file__).parent / "fixtures" / "study" / "paper_tables.toml").read_text("utf-8"))


def _apportion(percent: list[int], total: int) -> list[int]:
    """Whole counts summing to ``total`` in the proportions of ``percent`` (largest remainders):
    the table's rows are rounded means of two turns and sum to 100 or 101 %."""
    quotas = [p * total / sum(percent) for p in percent]
    counts = [math.floor(q) for q in quotas]
    for index in sorted(range(len(quotas)), key=lambda i: counts[i] - quotas[i])[: total - sum(counts)]:
        counts[index] += 1
    return counts


def _table1_counts() -> list[list[int]]:
    table = PAPER["table1"]
    return [_apportion(row, table["participants"] * table["turns"]) for row in table["percent"]]


def _write(path: Path, rows: list[list[object]]) -> Path:
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(HEADER)
        writer.writerows(rows)
    return path


def _table1_csv(path: Path) -> Path:
    """One answer per participant, video and turn; participant k's answers spread over the rows."""
    table = PAPER["table1"]
    labels = table["labels"]
    rows: list[list[object]] = []
    for emotion, counts in zip(labels, _table1_counts(), strict=True):
        responses = [label for label, count in zip(labels, counts, strict=True) for _ in range(count)]
        for index, response in enumerate(responses):
            participant, turn = divmod(index, table["turns"])
            rows.append([f"p{participant + 1:02d}", "label", emotion, "mse", response, f"{emotion}.mp4", turn + 1, ""])
    return _write(path, rows)


def _table2_csv(path: Path) -> Path:
    table = PAPER["table2"]
    rows: list[list[object]] = []
    for emotion, percent in zip(table["emotions"], table["percent"], strict=True):
        chosen = round(percent * table["participants"] / 100)
        for participant in range(table["participants"]):
            left, right = ("mse", "control") if participant % 2 else ("control", "mse")
            response = "mse" if participant < chosen else "control"
            rows.append([f"p{participant + 1:02d}", "pair", emotion, f"{left}|{right}", response, "", 1, "4.5"])
    return _write(path, rows)


def _analyze(capsys: pytest.CaptureFixture[str], *args: str) -> dict[str, object]:
    assert main(["study", "analyze", *args, "--format", "json"]) == 0
    report: dict[str, object] = json.loads(capsys.readouterr().out)
    return report


def test_table1_hit_rates_and_every_emotion_above_chance(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    table = PAPER["table1"]
    report = _analyze(capsys, str(_table1_csv(tmp_path / "table1.csv")))
    assert report["answers"] == 8 * 106 and report["participants"] == 53
    assert report["chance"] == table["chance_percent"] / 100 == 1 / len(table["labels"])
    labels = report["labels"]
    assert isinstance(labels, dict)
    for index, emotion in enumerate(table["labels"]):
        cell = labels[emotion]["mse"]
        # the rebuilt counts are within one answer of the paper's rounded percentages
        assert abs(100 * cell["hit_rate"] - table["percent"][index][index]) <= 1, emotion
        assert cell["ci"][0] < cell["hit_rate"] < cell["ci"][1]
        assert cell["ci"][0] > 0.125 and cell["significant"], emotion  # above chance, Holm-corrected
    confusion = report["confusion"]["mse"]  # type: ignore[index]
    assert confusion["counts"] == _table1_counts() and confusion["labels"] == table["labels"]


def test_table1_kappa_by_equation_1_read_literally(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """r_exp = the chance-expected number of responses (i·j / 8), h_exp = the chance-expected hits
    (j / 8): within 0.015 of the published row, none fitted (docs/study-analysis.md)."""
    table = PAPER["table1"]
    report = _analyze(capsys, str(_table1_csv(tmp_path / "table1.csv")))
    ours = [report["labels"][e]["mse"]["kappa"] for e in table["labels"]]  # type: ignore[index]
    differences = [abs(a - b) for a, b in zip(ours, table["kappa"], strict=True)]
    assert max(differences) < 0.016, list(zip(table["labels"], ours, table["kappa"], strict=True))
    assert ours.index(max(ours)) == 0  # anger highest, as in the paper
    assert ours.index(min(ours)) == 3  # embarrassment lowest, as in the paper


def test_table1_hits_against_the_strongest_confusion(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Section 5.2.2: anger, cheerfulness, panic fear and relief get their label significantly more
    often than any other (McNemar, p < .05); anxiety and embarrassment are confused with each other
    (p > .05).  Pride and tension the paper tests per turn (p = .066), which its table does not give."""
    report = _analyze(capsys, str(_table1_csv(tmp_path / "table1.csv")), "--correction", "none")
    labels = report["labels"]
    assert isinstance(labels, dict)
    strongest = {emotion: cells["mse"]["strongest_confusion"] for emotion, cells in labels.items()}
    for emotion in ("anger", "cheerfulness", "panic_fear", "relief"):
        assert strongest[emotion]["hits_exceed"], (emotion, strongest[emotion])
    assert strongest["anxiety"]["label"] == "embarrassment" and not strongest["anxiety"]["hits_exceed"]
    assert strongest["embarrassment"]["label"] == "anxiety" and not strongest["embarrassment"]["hits_exceed"]
    assert strongest["pride"]["label"] == "relief" and strongest["tension"]["label"] == "embarrassment"


def _readings(counts: list[list[int]]) -> dict[str, list[float]]:
    """The other readings of equation (1) docs/study-analysis.md lists, with what each gives."""
    m = np.array(counts, dtype=float)
    total, labels = m.sum(), m.shape[1]
    found: dict[str, list[float]] = {}
    for chance in ("uniform", "marginal"):
        for denominator in ("h_exp", "r_exp"):
            values = []
            for e in range(labels):
                answered, hits, given = m[e].sum(), m[e, e], m[:, e].sum()
                rejections = (total - answered) - (given - hits)
                p = 1 / labels if chance == "uniform" else given / total
                h_exp, cr_exp = answered * p, (total - answered) * (1 - p)
                r_exp = h_exp + cr_exp
                values.append(((hits + rejections) - r_exp) / (total - (h_exp if denominator == "h_exp" else r_exp)))
            found[f"{chance}/{denominator}"] = values
    return found


def test_table1_kappa_other_readings_do_not_give_the_published_row() -> None:
    """r_exp read as the chance-expected number of *correct* responses (hits + rejections), with chance
    1/8 or the label's share of all answers, and the denominator as printed (i·j − h_exp) or as in
    Cohen's κ (i·j − r_exp): the numbers docs/study-analysis.md reports, all far from 0.87 … 0.75."""
    counts = _table1_counts()
    documented = {  # docs/study-analysis.md, "κ of equation (1)"
        "uniform/h_exp": [0.207, 0.058, 0.136, 0.041, 0.165, 0.107, 0.132, 0.088],
        "marginal/h_exp": [0.206, 0.072, 0.143, 0.064, 0.133, 0.089, 0.141, 0.086],
        "uniform/r_exp": [0.93, 0.261, 0.612, 0.186, 0.741, 0.482, 0.596, 0.396],
        "marginal/r_exp": [0.93, 0.304, 0.624, 0.261, 0.7, 0.437, 0.61, 0.391],
    }
    for name, values in _readings(counts).items():
        assert [round(v, 3) for v in values] == documented[name], name
        assert max(abs(a - b) for a, b in zip(values, PAPER["table1"]["kappa"], strict=True)) > 0.3
    literal = [unbiased_kappa(counts, e, e, 8) for e in range(8)]
    assert [round(v, 3) for v in literal] == [0.873, 0.725, 0.803, 0.708, 0.831, 0.774, 0.799, 0.755]


def test_table2_believability_verdict_with_the_papers_test(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    table = PAPER["table2"]
    results = _table2_csv(tmp_path / "table2.csv")
    # the rebuilt counts are the paper's: their sample standard deviations are Table 2's
    for percent, sd in zip(table["percent"], table["sd"], strict=True):
        k, n = round(percent * table["participants"] / 100), table["participants"]
        assert round(math.sqrt(k * (n - k) / (n * (n - 1))), 3) == pytest.approx(sd, abs=0.0011)
    for test in (table["test"], "binomial"):  # the exact test agrees with the paper's χ²
        report = _analyze(capsys, str(results), "--preference-test", test, "--correction", "none")
        preference = report["preference"]
        assert isinstance(preference, dict)
        assert sorted(e for e, p in preference.items() if p["significant"]) == table["significant"]
        assert sorted(e for e, p in preference.items() if not p["significant"]) == table["not_significant"]
        for emotion, percent in zip(table["emotions"], table["percent"], strict=True):
            assert preference[emotion]["n"] == 42 and round(100 * preference[emotion]["share"]) == percent
            assert preference[emotion]["against"] == "control"
            assert preference[emotion]["left_share"] == pytest.approx(0.5, abs=0.05)
    # Holm's correction over the eight tests takes anxiety (28 of 42, χ² p = 0.031, adjusted 0.092)
    # below significance
    report = _analyze(capsys, str(results), "--preference-test", "chi2")
    anxiety = report["preference"]["anxiety"]  # type: ignore[index]
    assert anxiety["p"] == pytest.approx(0.0308, abs=1e-4) and not anxiety["significant"]


def test_simulated_study_recovers_the_confusion_matrix(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Participants answer from a known confusion matrix (two conditions) and a known believability
    preference; the analysis gives back every cell within sampling error."""
    labels = ["anger", "joy", "other", "relief", "sadness"]
    emotions = ["anger", "joy", "relief", "sadness"]
    truth = {
        "mse": [[0.8, 0.05, 0.05, 0.0, 0.1], [0.0, 0.7, 0.1, 0.2, 0.0], [0.0, 0.3, 0.1, 0.6, 0.0],
                [0.1, 0.0, 0.2, 0.0, 0.7]],
        "image": [[0.5, 0.1, 0.2, 0.0, 0.2], [0.1, 0.3, 0.3, 0.2, 0.1], [0.1, 0.2, 0.2, 0.3, 0.2],
                  [0.2, 0.2, 0.3, 0.1, 0.2]],
    }
    preference = {"anger": 0.85, "joy": 0.5, "relief": 0.75, "sadness": 0.5}
    rng = np.random.default_rng(34)
    participants = 150
    for participant in range(participants):
        rows: list[list[object]] = []
        for condition, matrix in truth.items():
            for emotion, row in zip(emotions, matrix, strict=True):
                response = labels[rng.choice(len(labels), p=row)]
                rows.append([f"s{participant}", "label", emotion, condition, response, f"{emotion}-{condition}", "",
                             f"{rng.uniform(2, 9):.2f}"])
        for emotion, share in preference.items():
            order = "mse|control" if rng.random() < 0.5 else "control|mse"
            rows.append([f"s{participant}", "pair", emotion, order, "mse" if rng.random() < share else "control",
                         "", "", ""])
        _write(tmp_path / f"participant-{participant:03d}.csv", rows)
    report = _analyze(capsys, str(tmp_path), "--labels", ",".join(labels))
    assert report["answers"] == participants * 12 and report["participants"] == participants
    assert report["chance"] == 0.2 and report["labels_from"] == "--labels"
    covered: list[bool] = []
    for condition, matrix in truth.items():
        confusion = report["confusion"][condition]  # type: ignore[index]
        assert confusion["emotions"] == emotions
        for emotion, row, counts in zip(emotions, matrix, confusion["counts"], strict=True):
            assert sum(counts) == participants
            observed = dict(zip(confusion["labels"], counts, strict=True))
            for label, p in zip(labels, row, strict=True):
                error = math.sqrt(p * (1 - p) / participants)
                assert abs(observed[label] / participants - p) <= 4 * error + 1e-9, (condition, emotion, label)
            cell = report["labels"][emotion][condition]  # type: ignore[index]
            true_rate = row[labels.index(emotion)]
            covered.append(cell["ci"][0] <= true_rate <= cell["ci"][1])
            if true_rate >= 0.5:  # far above chance (0.2): found at any seed
                assert cell["significant"], (emotion, condition, cell)
        agreement = report["agreement"][condition]  # type: ignore[index]
        assert agreement["subjects"] == 4 and agreement["ratings"] == participants
    assert sum(covered) >= 6  # of 8 95 % intervals hold the true hit rate (3 misses: p < 0.01)
    assert report["agreement"]["mse"]["fleiss_kappa"] > report["agreement"]["image"]["fleiss_kappa"]  # type: ignore[index]
    for emotion, share in preference.items():
        result = report["preference"][emotion]  # type: ignore[index]
        assert abs(result["share"] - share) <= 4 * math.sqrt(share * (1 - share) / participants) + 1e-9
        assert result["significant"] == (share > 0.6)


def test_markdown_report_with_heatmaps(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("PIL")
    from PIL import Image

    results = _table1_csv(tmp_path / "table1.csv")
    _table2_csv(tmp_path / "table2.csv")
    out = tmp_path / "report"
    assert main(["study", "analyze", str(results), str(tmp_path / "table2.csv"), "-o", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["confusion-mse.png", "report.json", "report.md"]
    text = (out / "report.md").read_text("utf-8")
    assert "![confusion matrix, mse](confusion-mse.png)" in text
    assert "Multiple comparisons: Holm–Bonferroni" in text
    assert "| anger | mse | 106 | 99 | 93.4 % * |" in text
    assert "| embarrassment | control | 42 | 23 | 54.8 % |" in text and "no preference shown" in text
    with Image.open(out / "confusion-mse.png") as image:
        assert image.format == "PNG" and image.width > 8 * 40 and image.height > 8 * 40
        pixels = np.asarray(image.convert("RGB"), dtype=int)
    assert (pixels[..., 2] - pixels[..., 0] > 200).any()  # a dark (high-share) cell is drawn
    json_report = json.loads((out / "report.json").read_text("utf-8"))
    assert set(json_report["preference"]) == set(PAPER["table2"]["emotions"])
    assert "report.md" in capsys.readouterr().out


BAD = [
    ("participant,task,emotion\np1,label,anger\n", "bad.csv:1:1: E170 the header row lacks the columns condition, "
     "response"),
    ("", "bad.csv: E170 empty results file"),
    ("participant,task,emotion,condition,response,response\n", "bad.csv:1:"),
    ("participant,task,emotion,condition,response\np1,rate,anger,mse,anger\n",
     "bad.csv:2:4: E171 task 'rate' must be one of label, pair"),
    ("participant,task,emotion,condition,response\n,label,anger,mse,anger\n", "bad.csv:2:1: E171 empty participant"),
    ("participant,task,emotion,condition,response\np1,label,anger,mse\n", "bad.csv:2:1: E171 4 cells"),
    ("participant,task,emotion,condition,response\np1,label,anger rage,mse,anger\n",
     "bad.csv:2:10: E171 emotion 'anger rage' must be a name"),
    ("participant,task,emotion,condition,response\np1,label,anger,mse|control,anger\n",
     "bad.csv:2:16: E171 a label answer has one condition"),
    ("participant,task,emotion,condition,response\np1,pair,anger,mse,mse\n",
     "bad.csv:2:15: E171 a pair's condition 'mse' must be two conditions"),
    ("participant,task,emotion,condition,response\np1,pair,anger,mse|mse,mse\n",
     "bad.csv:2:15: E171 a pair shows two different conditions"),
    ("participant,task,emotion,condition,response\np1,pair,anger,image|control,image\n",
     "bad.csv:2:15: E171 a believability pair compares 'mse'"),
    ("participant,task,emotion,condition,response\np1,pair,anger,mse|control,image\n",
     "bad.csv:2:27: E171 a pair's response 'image' must be one of the conditions shown"),
    ("participant,task,emotion,condition,response,trial\np1,label,anger,mse,anger,-1\n",
     "bad.csv:2:26: E171 trial '-1' must be a whole number"),
    ("participant,task,emotion,condition,response,seconds\np1,label,anger,mse,anger,nan\n",
     "bad.csv:2:26: E171 seconds 'nan' must be a finite number"),
    ('participant,task,emotion,condition,response\np1,label,"anger,mse,anger\n',
     "bad.csv:2:1: E170 not a readable CSV"),
    (b"participant,task,emotion,condition,response\np1,label,\xff,mse,anger\n".decode("latin-1"),
     "bad.csv:2:10: E170 results file is not valid UTF-8"),
    ("participant,task,emotion,condition,response\n", "bad.csv: E170 no answers in the results"),
]


@pytest.mark.parametrize(("content", "expected"), BAD)
def test_bad_results_are_located_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                        monkeypatch: pytest.MonkeyPatch, content: str, expected: str) -> None:
    monkeypatch.chdir(tmp_path)
    data = content.encode("latin-1") if "\xff" in content else content.encode("utf-8")
    (tmp_path / "bad.csv").write_bytes(data)
    assert main(["study", "analyze", "bad.csv", "-o", "out"]) == 1
    captured = capsys.readouterr()
    assert captured.out == "" and "Traceback" not in captured.err
    assert captured.err.startswith(expected), captured.err
    assert not (tmp_path / "out").exists()  # nothing half-written


def test_bad_arguments_and_labels(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    results = _write(tmp_path / "r.csv", [["p1", "label", "anger", "mse", "joy", "", "", ""],
                                          ["p1", "label", "joy", "mse", "other", "", "", ""]])
    assert main(["study", "analyze", str(results), "--labels", "anger,joy"]) == 1
    assert capsys.readouterr().err == f"{results}:3:1: E171 response 'other' is not one of --labels\n"
    assert main(["study", "analyze", str(results), "--labels", "anger,anger"]) == 1
    assert capsys.readouterr().err == "<arguments>: E130 --labels names a label twice\n"
    assert main(["study", "analyze", str(results), "--level", "95"]) == 1
    assert "E130 --level must be between 0 and 1" in capsys.readouterr().err
    assert main(["study", "analyze", str(tmp_path / "missing.csv")]) == 1
    assert "missing.csv: E100 cannot read results file" in capsys.readouterr().err
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["study", "analyze", str(empty)]) == 1
    assert capsys.readouterr().err == f"{empty}: E170 no results (*.csv) in this folder\n"
    one = _write(tmp_path / "one.csv", [["p1", "label", "anger", "mse", "anger", "", "", ""]])
    assert main(["study", "analyze", str(one)]) == 1
    assert "name the labels offered with --labels" in capsys.readouterr().err


def test_emotion_outside_labels_and_too_many_names(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    results = _write(tmp_path / "r.csv", [["p1", "label", "anger", "mse", "joy", "", "", ""]])
    assert main(["study", "analyze", str(results), "--labels", "joy,other"]) == 1
    assert capsys.readouterr().err == f"{results}:2:1: E171 emotion 'anger' is not one of --labels\n"
    many = _write(tmp_path / "many.csv", [["p1", "label", f"e{i}", "mse", f"r{i}", "", "", ""] for i in range(60)])
    assert main(["study", "analyze", str(many)]) == 1
    assert capsys.readouterr().err == f"{many}:52:1: E171 more than 100 distinct emotions and labels in the results\n"
