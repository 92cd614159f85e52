"""mse study: balanced Latin squares, make (stimuli, manifest, regeneration), bad input,
the server against bad clients, and the page clicked through in headless Chromium."""

from __future__ import annotations

import contextlib
import csv
import http.client
import itertools
import json
import os
import select
import shutil
import subprocess
import sys
import time
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mse.cli import main
from mse.cli.cmd_study import run_mse
from mse.study.design import RESULT_COLUMNS
from mse.study.latin import balanced_latin_square
from mse.study.make import regenerate

REPO = Path(__file__).resolve().parent.parent
FAST = ["-d", "1", "--size", "96x64", "--fps", "4"]


# --- balanced Latin squares -------------------------------------------------------------------

@pytest.mark.parametrize("n", range(1, 10))
def test_balanced_latin_square(n: int) -> None:
    rows = balanced_latin_square(n)
    squares = [rows[:n], rows[n:]] if n % 2 else [rows]
    assert len(rows) == (2 * n if n % 2 else n)
    for square in squares:  # a Latin square: every item once in every row and every position
        assert all(sorted(row) == list(range(n)) for row in square)
        assert all(sorted(column) == list(range(n)) for column in zip(*square, strict=True))
    neighbours = Counter(pair for row in rows for pair in itertools.pairwise(row))
    expected = 2 if n % 2 else 1  # Williams: once (even n), twice over the 2n rows (odd n)
    assert set(neighbours) == {(a, b) for a in range(n) for b in range(n) if a != b}
    assert set(neighbours.values()) <= {expected}


# --- make -------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("study") / "s"
    code = main(["study", "make", "--emotions", "anger,relief", "-o", str(out), "--seed", "7", "--participants",
                 "4", "--face-only", "-q", *FAST])
    assert code == 0
    return out


def _manifest(folder: Path) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((folder / "manifest.json").read_text(encoding="utf-8"))
    return data


def test_make_writes_every_condition_with_equal_framing(study: Path) -> None:
    av = pytest.importorskip("av")
    from PIL import Image

    manifest = _manifest(study)
    assert manifest["seed"] == 7
    assert manifest["labels"] == ["anger", "relief", "other"]
    assert manifest["columns"] == list(RESULT_COLUMNS)
    kinds = Counter((s["emotion"], s["condition"]) for s in manifest["stimuli"])
    assert kinds == {(e, c): 1 for e in ("anger", "relief") for c in ("mse", "control", "image", "face")}
    for stimulus in manifest["stimuli"]:
        path = study / stimulus["file"]
        assert stimulus["id"] not in ("anger", "relief") and stimulus["emotion"] not in stimulus["file"]
        if stimulus["kind"] == "image":
            assert Image.open(path).size == (96, 64)
            assert 0 <= stimulus["apex"] <= 1
        else:
            with av.open(str(path)) as container:
                video = container.streams.video[0]
                assert (video.codec_context.width, video.codec_context.height) == (96, 64)
                assert sum(1 for _ in container.decode(video)) == 4  # 1 s at 4 fps
    by_id = {s["id"]: s for s in manifest["stimuli"]}
    for stimulus in manifest["stimuli"]:  # the control and the image come from the MSE stimulus' seed
        if stimulus["condition"] == "face":
            source = by_id[stimulus["derived_from"]]
            kept = json.loads((study / stimulus["timeline"]).read_text(encoding="utf-8"))["signals"]
            whole = json.loads((study / source["timeline"]).read_text(encoding="utf-8"))["signals"]
            assert kept == [s for s in whole if s["modality"] in ("face", "gaze", "head")]
    seeds = {(s["emotion"], s["condition"]): s["seed"] for s in manifest["stimuli"]}
    assert seeds["anger", "mse"] == seeds["anger", "control"] == seeds["anger", "image"]
    control = next(s for s in manifest["stimuli"] if s["condition"] == "control")
    assert "constraint-less" in control["commands"][0]


def test_orders_are_counterbalanced(study: Path) -> None:
    manifest = _manifest(study)
    ids = sorted(s["id"] for s in manifest["stimuli"])
    participants = manifest["participants"]
    assert [p["id"] for p in participants] == ["p01", "p02", "p03", "p04"]
    assert all(sorted(p["labels"]) == ids for p in participants)
    firsts = [p["labels"][0] for p in participants]
    assert len(set(firsts)) == len(firsts)
    by_id = {s["id"]: s for s in manifest["stimuli"]}
    sides = Counter(by_id[pair["left"]]["condition"] for p in participants for pair in p["pairs"])
    assert sides["mse"] == sides["control"]
    for p in participants:
        assert sorted(pair["emotion"] for pair in p["pairs"]) == ["anger", "relief"]


@pytest.mark.parametrize("condition", ["mse", "image", "face"])
def test_a_stimulus_regenerates_byte_for_byte(study: Path, tmp_path: Path, condition: str) -> None:
    stimulus = next(s for s in _manifest(study)["stimuli"] if s["condition"] == condition)
    again = regenerate(study, stimulus["id"], tmp_path, run_mse)
    assert again.read_bytes() == (study / stimulus["file"]).read_bytes()


def test_manifest_command_runs_as_a_shell_command(study: Path, tmp_path: Path) -> None:
    """The first command of a stimulus, run by the mse executable from the study folder's layout."""
    stimulus = next(s for s in _manifest(study)["stimuli"] if s["condition"] == "control")
    (tmp_path / "timelines").mkdir()
    argv = [sys.executable, "-m", "mse", *stimulus["commands"][0][1:]]
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    subprocess.run(argv, cwd=tmp_path, check=True, env=env, timeout=60)
    assert (tmp_path / stimulus["timeline"]).read_bytes() == (study / stimulus["timeline"]).read_bytes()


def test_make_refuses_a_non_empty_folder_unless_forced(study: Path, tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "s"
    out.mkdir()
    (out / "notes.txt").write_text("mine", encoding="utf-8")
    args = ["study", "make", "--emotions", "anger", "-o", str(out), "--seed", "1", "-q", *FAST]
    assert main(args) == 1
    assert "not empty" in capsys.readouterr().err
    assert main([*args, "--force"]) == 1  # not a study: never deleted
    assert "replaces only a study folder" in capsys.readouterr().err
    assert [p.name for p in out.iterdir()] == ["notes.txt"]
    (out / "notes.txt").unlink()
    assert main(args) == 0  # an empty folder is fine
    (out / "stimuli" / "mine.txt").write_text("mine", encoding="utf-8")
    assert main(args) == 1
    assert main([*args, "--force"]) == 0  # a study made before is replaced, whole
    assert not (out / "stimuli" / "mine.txt").exists() and (out / "manifest.json").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no staging folder left


def test_force_never_deletes_an_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "s"
    assert main(["study", "make", "--emotions", "anger", "-o", str(out), "--seed", "1", "-q", *FAST]) == 0
    source = out / "mine.xml"
    shutil.copy(REPO / "behaviour_sets" / "tension.xml", source)
    assert main(["study", "make", "--emotions", str(source), "-o", str(out), "--force", "-q", *FAST]) == 1
    assert "would delete" in capsys.readouterr().err
    assert source.exists()


def test_study_without_a_subcommand_shows_help(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["study"]) == 2
    assert "make" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("emotions", "message"),
    [
        ("angr", "did you mean 'anger'"),
        ("anger,,relief", "comma-separated"),
        ("", "comma-separated"),
        ("anger,anger", "given twice"),
    ],
)
def test_make_bad_emotions(tmp_path: Path, capsys: pytest.CaptureFixture[str], emotions: str, message: str) -> None:
    out = tmp_path / "s"
    assert main(["study", "make", "--emotions", emotions, "-o", str(out), *FAST]) != 0
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not out.exists() and not list(tmp_path.iterdir())


def test_make_unwritable_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("", encoding="utf-8")
    assert main(["study", "make", "--emotions", "anger", "-o", str(blocker / "s"), *FAST]) == 1
    err = capsys.readouterr().err
    assert "cannot write the study" in err and "Traceback" not in err


def test_make_a_behaviour_set_path(tmp_path: Path) -> None:
    source = REPO / "behaviour_sets" / "tension.xml"
    out = tmp_path / "s"
    assert main(["study", "make", "--emotions", str(source), "-o", str(out), "--seed", "2", "-q", *FAST]) == 0
    manifest = _manifest(out)
    assert manifest["labels"] == ["tension", "other"]
    assert manifest["stimuli"][0]["commands"][0][2] == str(source)


# --- the server -------------------------------------------------------------------------------

@pytest.fixture()
def served(study: Path, tmp_path: Path) -> Iterator[tuple[Path, str]]:
    """A copy of the study served by ``mse study serve --port 0``: (folder, base URL)."""
    with _serve(study, tmp_path) as running:
        yield running


@contextlib.contextmanager
def _serve(study: Path, tmp_path: Path) -> Iterator[tuple[Path, str]]:
    folder = tmp_path / "study"
    shutil.copytree(study, folder)
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    process = subprocess.Popen([sys.executable, "-m", "mse", "study", "serve", str(folder), "--port", "0"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        assert process.stdout is not None
        ready, _, _ = select.select([process.stdout], [], [], 30)
        assert ready, "the server did not start"
        line = process.stdout.readline()
        assert line.startswith("serving "), line
        yield folder, line.split(" at ")[1].split()[0]
    finally:
        process.terminate()
        process.wait(timeout=10)
        assert process.stderr is not None
        assert "Traceback" not in process.stderr.read()


def _request(url: str, method: str, path: str, body: bytes | None = None,
             headers: dict[str, str] | None = None) -> tuple[int, str]:
    host_port = url.split("//")[1].rstrip("/")
    connection = http.client.HTTPConnection(host_port, timeout=10)
    try:
        connection.request(method, path, body=body, headers=headers or {})
        reply = connection.getresponse()
        return reply.status, reply.read().decode("utf-8", "replace")
    finally:
        connection.close()


def _good_csv(folder: Path, participant: str) -> str:
    manifest = _manifest(folder)
    stimulus = manifest["stimuli"][0]
    rows = [list(RESULT_COLUMNS),
            [participant, "label", stimulus["emotion"], stimulus["condition"], "other", stimulus["id"], "1", "0.5"]]
    return "".join(",".join(row) + "\r\n" for row in rows)


def test_server_survives_bad_clients(served: tuple[Path, str]) -> None:
    folder, url = served
    good = _good_csv(folder, "p01")
    bad_requests: list[tuple[str, bytes | None, dict[str, str]]] = [
        ("/elsewhere", good.encode(), {}),
        ("/results/..%2Fmanifest", good.encode(), {}),
        ("/results/p99", good.encode(), {}),
        ("/results/p01", b"\xff\xfe not utf-8", {}),
        ("/results/p01", b"a,b\r\n1,2\r\n", {}),
        ("/results/p01", good.replace("other", "joy").encode(), {}),
        ("/results/p01", good.replace(",1,0.5", ",1,-3").encode(), {}),
        ("/results/p01", _good_csv(folder, "p02").encode(), {}),
        ("/results/p01", None, {"Content-Length": "99999999"}),
    ]
    for path, body, headers in bad_requests:
        status, text = _request(url, "POST", path, body, headers)
        assert 400 <= status < 500, (path, status, text)
    # a client that announces more than it sends and hangs up
    host, port = url.split("//")[1].rstrip("/").split(":")
    import socket

    with socket.create_connection((host, int(port)), timeout=5) as raw:
        raw.sendall(b"POST /results/p01 HTTP/1.1\r\nHost: x\r\nContent-Length: 500\r\n\r\nparticipant,")
    with socket.create_connection((host, int(port)), timeout=5) as raw:
        raw.sendall(b"GARBAGE\r\n\r\n")
        raw.recv(1000)
    assert not (folder / "results" / "p01.csv").exists()
    status, text = _request(url, "POST", "/results/p01", good.encode())
    assert status == 200, text
    assert (folder / "results" / "p01.csv").read_bytes() == good.encode()
    assert _request(url, "POST", "/results/p01", good.encode())[0] == 409  # never replaced
    assert _request(url, "GET", "/results/p01.csv")[0] == 403
    assert _request(url, "GET", "/index.html")[0] == 200


def test_serve_bad_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["study", "serve", str(tmp_path), "--port", "0"]) == 1
    assert "not a study folder" in capsys.readouterr().err
    assert main(["study", "serve", str(tmp_path), "--port", "70000"]) != 0


# --- the page in headless Chromium ------------------------------------------------------------

def _state(driver: Any) -> str:
    return str(driver.execute_script("return document.body.dataset.state"))


def _wait(driver: Any, states: tuple[str, ...], timeout: float = 30.0) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        state = _state(driver)
        if state in states:
            return state
        assert state != "error", driver.find_element("id", "trial-error").text
        time.sleep(0.05)
    raise AssertionError(f"page stuck in state {_state(driver)!r}, waiting for {states}")


def take_part(driver: Any, url: str, participant: str, answer: Any) -> str:
    """Click through the study as ``participant``; ``answer(trial)`` returns the response to click
    (a label, or ``left``/``right``).  Returns the final state of the page."""
    driver.get(url)
    driver.find_element("id", "participant").send_keys(participant)
    driver.find_element("id", "begin").click()
    while True:
        state = _wait(driver, ("answer", "saved", "downloaded", "download"))
        if state != "answer":
            return state
        question = driver.find_element("id", "question").text
        stimuli = [f.get_attribute("src").rsplit("/", 1)[1].split(".")[0]
                   for f in driver.find_elements("css selector", "#stage video, #stage img")]
        response = answer(question, stimuli)
        progress = driver.find_element("id", "progress").text
        driver.find_element("css selector", f'#choices button[data-response="{response}"]').click()
        deadline = time.monotonic() + 10
        while driver.find_element("id", "progress").text == progress and _state(driver) == "answer":
            assert time.monotonic() < deadline
            time.sleep(0.02)


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8", newline="") as handle:
        reader = csv.DictReader(handle)
        assert tuple(reader.fieldnames or ()) == RESULT_COLUMNS
        return list(reader)


def test_a_participant_through_the_served_page(driver: Any, served: tuple[Path, str]) -> None:
    folder, url = served
    manifest = _manifest(folder)
    by_id = {s["id"]: s for s in manifest["stimuli"]}

    def answer(question: str, stimuli: list[str]) -> str:
        if "believable" in question:
            return "left"
        return str(by_id[stimuli[0]]["emotion"])

    state = take_part(driver, f"{url}?participant=p02", "", answer)
    assert state == "saved"
    rows = _rows(folder / "results" / "p02.csv")
    plan = next(p for p in manifest["participants"] if p["id"] == "p02")
    assert [r["stimulus"] for r in rows] == [*plan["labels"], *(f"{p['left']}|{p['right']}" for p in plan["pairs"])]
    assert [int(r["trial"]) for r in rows] == list(range(1, len(rows) + 1))
    for row in rows:
        assert row["participant"] == "p02" and float(row["seconds"]) >= 0
        if row["task"] == "label":
            assert row["response"] == row["emotion"] == by_id[row["stimulus"]]["emotion"]
            assert row["condition"] == by_id[row["stimulus"]]["condition"]
        else:
            left, right = row["stimulus"].split("|")
            assert row["condition"] == f"{by_id[left]['condition']}|{by_id[right]['condition']}"
            assert row["response"] == by_id[left]["condition"]


def test_the_page_from_file_downloads_the_csv(driver: Any, study: Path, tmp_path: Path) -> None:
    downloads = tmp_path / "downloads"
    downloads.mkdir()
    driver.execute_cdp_cmd("Browser.setDownloadBehavior", {"behavior": "allow", "downloadPath": str(downloads)})
    state = take_part(driver, (study / "index.html").as_uri() + "?participant=p03", "",
                      lambda question, stimuli: "right" if "believable" in question else "other")
    assert state == "downloaded"
    deadline = time.monotonic() + 10
    while not (downloads / "p03.csv").exists():
        assert time.monotonic() < deadline, "no download"
        time.sleep(0.05)
    rows = _rows(downloads / "p03.csv")
    assert len(rows) == len(_manifest(study)["stimuli"]) + 2


def test_unknown_participant_is_refused(driver: Any, study: Path) -> None:
    driver.get((study / "index.html").as_uri())
    driver.find_element("id", "participant").send_keys("nobody")
    driver.find_element("id", "begin").click()
    assert "Unknown participant" in driver.find_element("id", "start-error").text
    assert _state(driver) == "start"


@pytest.mark.slow
def test_simulated_study_recovers_the_confusion_matrix(driver: Any, tmp_path: Path) -> None:
    """Participants answer from a known confusion matrix (by quota, so the counts are exact) and
    a believability share; counting the CSVs the page wrote gives both back."""
    made = tmp_path / "made"
    assert main(["study", "make", "--emotions", "anger,relief", "-o", str(made), "--seed", "11", "--participants",
                 "4", "-q", "-d", "1", "--size", "64x48", "--fps", "4"]) == 0
    with _serve(made, tmp_path) as (folder, url):
        _simulate(driver, folder, url)
        _analyze_recovers(folder, tmp_path)


def _analyze_recovers(folder: Path, tmp_path: Path) -> None:
    """make -> page -> CSV -> ``mse study analyze``: the report gives the simulated matrix back."""
    report = tmp_path / "report"
    assert main(["study", "analyze", str(folder / "results"), "-o", str(report),
                 "--labels", "anger,relief,other"]) == 0  # fmt: skip
    result = json.loads((report / "report.json").read_text(encoding="utf-8"))
    # per condition (mse, control, image) each emotion is shown once to each of 4 participants
    hit_rates = {"anger": 0.75, "relief": 0.5}
    for emotion, by_condition in result["labels"].items():
        answers = sum(cell["n"] for cell in by_condition.values())
        hits = sum(cell["hit_rate"] * cell["n"] for cell in by_condition.values())
        assert answers == 12 and round(hits) == round(hit_rates[emotion] * answers)
    summed: dict[str, Counter[str]] = {e: Counter() for e in hit_rates}
    for matrix in result["confusion"].values():
        for emotion, counts in zip(matrix["emotions"], matrix["counts"], strict=True):
            summed[emotion].update(dict(zip(matrix["labels"], counts, strict=True)))
    assert summed == {"anger": Counter(anger=9, other=3, relief=0), "relief": Counter(anger=3, relief=6, other=3)}
    preferences = {e: (p["n"], p["share"]) for e, p in result["preference"].items()}
    assert preferences == {"anger": (4, 0.75), "relief": (4, 0.5)}
    assert (report / "report.md").is_file() and list(report.glob("*.png"))


def _simulate(driver: Any, folder: Path, url: str) -> None:
    manifest = _manifest(folder)
    by_id = {s["id"]: s for s in manifest["stimuli"]}
    participants = [p["id"] for p in manifest["participants"]]
    answers_per_emotion = len(participants) * len(manifest["conditions"])  # 4 x 3
    confusion = {"anger": {"anger": 0.75, "relief": 0.0, "other": 0.25},
                 "relief": {"anger": 0.25, "relief": 0.5, "other": 0.25}}
    prefer_mse = {"anger": 0.75, "relief": 0.5}
    quotas = {e: iter([label for label, share in row.items() for _ in range(round(share * answers_per_emotion))])
              for e, row in confusion.items()}
    pair_quotas = {e: iter([True] * round(share * 4) + [False] * round((1 - share) * 4))
                   for e, share in prefer_mse.items()}

    def answer(question: str, stimuli: list[str]) -> str:
        emotion = by_id[stimuli[0]]["emotion"]
        if "believable" in question:
            mse_side = "left" if by_id[stimuli[0]]["condition"] == "mse" else "right"
            return mse_side if next(pair_quotas[emotion]) else ("right" if mse_side == "left" else "left")
        return next(quotas[emotion])

    for participant in participants:
        assert take_part(driver, f"{url}?speed=8", participant, answer) == "saved"
    rows = [row for p in participants for row in _rows(folder / "results" / f"{p}.csv")]
    counted: dict[str, Counter[str]] = {e: Counter() for e in confusion}
    preferred: dict[str, list[bool]] = {e: [] for e in confusion}
    for row in rows:
        if row["task"] == "label":
            counted[row["emotion"]][row["response"]] += 1
        else:
            preferred[row["emotion"]].append(row["response"] == "mse")
    for emotion, row in confusion.items():
        total = sum(counted[emotion].values())
        assert total == answers_per_emotion
        assert {label: counted[emotion][label] / total for label in row} == row
        assert sum(preferred[emotion]) / len(preferred[emotion]) == prefer_mse[emotion]


def test_titles_are_left_out(study: Path) -> None:
    """A title names the emotion: every render command carries --no-title and --no-strip."""
    renders = [argv for s in _manifest(study)["stimuli"] for argv in s["commands"] if argv[1] == "render"]
    assert renders and all("--no-title" in argv and "--no-strip" in argv for argv in renders)


def test_every_stimulus_shows_a_face_signal(study: Path) -> None:
    """A draw may be empty; the seed each stimulus settles on shows the face, and the image is taken
    where a face signal plays."""
    manifest = _manifest(study)
    for stimulus in manifest["stimuli"]:
        timeline = json.loads((study / stimulus["timeline"]).read_text(encoding="utf-8"))
        if stimulus["condition"] in ("mse", "image"):
            faces = [s for s in timeline["signals"] if s["modality"] == "face"]
            assert faces, stimulus["id"]
        if stimulus["condition"] == "image":
            assert any(s["start"] <= stimulus["apex"] < s["stop"] for s in faces), stimulus["id"]
