"""``mse serve`` (docs/serve.md): a real server on 127.0.0.1 talked to with the real ``websockets``
client: the protocol, the clocks, every kind of bad message answered, the service's limits."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import jsonschema
import pytest

pytest.importorskip("websockets")

from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from mse.dialogue.check import check_dialogue
from mse.serve.client import Client
from mse.serve.protocol import SCHEMA
from mse.timeline import Timeline
from tests.serve_server import BackgroundServer

ROOT = Path(__file__).resolve().parent.parent
_SCHEMA = json.loads(SCHEMA.read_text(encoding="utf-8"))


def _valid(message: dict[str, Any], direction: str) -> None:
    jsonschema.validate(message, {**_SCHEMA, "$ref": f"#/$defs/{direction}"})


@pytest.fixture(scope="module")
def server() -> Any:
    with BackgroundServer() as running:
        yield running


def test_a_dialogue_on_the_script_clock(server: BackgroundServer) -> None:
    messages = [
        {"type": "hello", "protocol": 1, "seed": 4, "clock": "script", "bml": True, "keep": True},
        {"t": 0, "emotion": "anger", "intensity": 0.8, "until": 3.7},
        {"t": 0.4, "say": "I can't believe you did that", "stress": ["believe"]},
        {"t": 3.7, "emotion": "relief"},
        {"t": 8.7, "end": True},
    ]
    received: list[dict[str, Any]] = []
    with Client(server.uri, timeout=30) as client:
        for message in messages:
            _valid(message, "in")
            answer = list(client.send(message))
            assert all(m["type"] != "error" for m in answer), answer
            received += answer
        (whole,) = client.send({"type": "timeline"})
        _valid({"type": "tracks", "format": "arkit-json"}, "in")
        (tracks,) = client.send({"type": "tracks", "format": "arkit-json"})
        (openface,) = client.send({"type": "tracks", "format": "openface"})
    _valid(tracks, "out")
    curves = json.loads(tracks["data"])
    assert "jawOpen" in curves["names"] and len(curves["frames"]) >= 8.7 * curves["fps"] - 1
    assert openface["data"].startswith("frame, face_id, timestamp")
    for message in received:
        _valid(message, "out")
    kinds = [m["type"] for m in received]
    assert kinds[0] == "hello" and received[0]["seed"] == 4
    assert {m["episode"] for m in received if m["type"] == "occurrence"} == {0, 1}
    assert [m["index"] for m in received if m["type"] == "episode"] == [0, 1]
    blocks = [m for m in received if m["type"] == "bml"]
    assert [b["composition"] for b in blocks] == ["MERGE", "REPLACE"]
    assert len({b["id"] for b in blocks}) == 2 and all(f'id="{b["id"]}"' in b["bml"] for b in blocks)
    timeline = Timeline.from_json(whole["timeline"])
    assert [e["emotion"] for e in timeline.episodes] == ["anger", "relief"]
    assert check_dialogue(timeline) == []
    # what was pushed is what the timeline holds: the last version of each occurrence
    pushed: dict[tuple[int, str, float], dict[str, Any]] = {}
    for m in received:
        if m["type"] == "occurrence":
            pushed[(m["episode"], m["id"], m["start"])] = m
    dropped = {(e["index"], d["id"], d["start"]) for e in timeline.episodes for d in e.get("dropped", [])}
    kept = {k: v for k, v in pushed.items() if k not in dropped}
    assert sorted(kept) == sorted((s.episode, s.id, s.start) for s in timeline.signals)
    assert all(kept[(s.episode, s.id, s.start)]["stop"] == s.stop for s in timeline.signals if s.episode is not None)


def test_the_real_clock_counts_from_the_first_event(server: BackgroundServer) -> None:
    with Client(server.uri, seed=1) as client:
        first = [m for m in client.send({"emotion": "tension"}) if m["type"] == "occurrence"]
        assert first and min(m["start"] for m in first) >= 0.0
        time.sleep(0.3)
        (clock,) = client.send({"type": "clock"})
        assert 0.3 <= clock["t"] < 5.0
        answer = list(client.send({"emotion": "relief"}))
        (closed,) = [m for m in answer if m["type"] == "episode"]
        assert 0.3 <= closed["stop"] < 5.0 and closed["interrupted"]  # the event happened now
        later = [m for m in answer if m["type"] == "occurrence" and m["episode"] == 1]
        assert later and min(m["start"] for m in later) >= closed["stop"]


def _bad_messages() -> list[tuple[str | bytes, str, str]]:
    """(message, expected code, a piece of the expected message), in the order sent: before
    the dialogue starts, then within it (script clock, started at t = 5), then after its end."""
    deep = "[" * 30000 + "]" * 30000
    return [
        ("not json", "bad-json", "not JSON"),
        ("[1, 2]", "bad-message", "JSON object"),
        ('"anger"', "bad-message", "JSON object"),
        (b"\x00\x01", "bad-message", "binary"),
        (deep, "bad-json", "not JSON"),
        ('{"t": NaN, "emotion": "anger"}', "bad-json", "NaN"),
        ("{}", "event", "exactly one of"),
        ('{"type": "nope"}', "unknown-type", "'nope'"),
        ('{"type": "hello", "protocol": 2}', "protocol", "speaks 1"),
        ('{"type": "hello", "clock": "sundial"}', "bad-message", "'clock'"),
        ('{"type": "hello", "seed": -1}', "bad-message", "'seed'"),
        ('{"type": "hello", "colour": "red"}', "bad-message", "'colour'"),
        ('{"t": 0, "emotion": "angr"}', "event", "anger"),
        ('{"t": 0, "emotion": "anger", "intensity": 2}', "event", "'intensity'"),
        ('{"t": "soon", "emotion": "anger"}', "event", "'t'"),
        ('{"t": 0, "emotion": "anger", "sad": 1}', "event", "'sad'"),
        ('{"t": 0, "say": "hello"}', "state", "before the first emotion"),
        ('{"t": 0, "end": true}', "state", "not started"),
        ('{"type": "timeline"}', "state", "no episode yet"),
        ('{"type": "hello", "clock": "script"}', "", ""),  # accepted: the dialogue starts below
        ('{"t": 5, "emotion": "anger"}', "", ""),
        ('{"t": 1, "emotion": "relief"}', "past", "before the session's last event"),
        ('{"emotion": "relief"}', "event", "script clock"),
        ('{"t": 6, "say": "hi", "words": [["hi", 5.5, 5.8]]}', "event", "before its utterance"),
        ('{"t": 6, "say": "hi", "stress": ["hello"]}', "event", "stressed word"),
        ('{"type": "hello"}', "state", "before the first event"),
        ('{"type": "timeline"}', "state", "keeps no timeline"),
        ('{"t": 9, "end": true}', "", ""),
        ('{"t": 10, "emotion": "anger"}', "state", "has ended"),
    ]


@pytest.mark.slow
def test_every_kind_of_bad_message_is_answered_and_the_session_goes_on(server: BackgroundServer) -> None:
    cases = _bad_messages()
    assert len({code + piece for _, code, piece in cases if code}) >= 20
    with connect(server.uri, max_size=None) as socket:
        for seq, (message, code, piece) in enumerate(cases, start=1):
            socket.send(message)
            answer: list[dict[str, Any]] = []
            while not answer or answer[-1]["type"] not in ("ack", "error"):
                answer.append(json.loads(socket.recv(timeout=30)))
            last = answer[-1]
            _valid(last, "out")
            if code:
                assert (last["code"], last["seq"]) == (code, seq), (message, last)
                assert piece in last["message"], (message, last)
                assert len(answer) == 1
            else:
                assert last == {"type": "ack", "seq": seq}, (message, answer)
    with Client(server.uri, clock="script") as client:  # still serving
        assert any(m["type"] == "occurrence" for m in client.send({"t": 0, "emotion": "pride"}))


def _closed_with(uri: str, send: list[str | bytes], **connect_options: Any) -> tuple[int, str]:
    with connect(uri, max_size=None, **connect_options) as socket:
        try:
            for message in send:
                socket.send(message)
            while True:
                socket.recv(timeout=30)
        except ConnectionClosed as closed:
            assert closed.rcvd is not None
            return closed.rcvd.code, closed.rcvd.reason
    raise AssertionError("not closed")


@pytest.mark.slow
def test_limits_close_with_a_code_and_a_reason() -> None:
    with BackgroundServer(max_sessions=2, max_message=1000, max_rate=20) as server:
        assert _closed_with(server.uri, ['{"say": "' + "a" * 2000 + '"}'])[0] == 1009
        with Client(server.uri), Client(server.uri):
            code, reason = _closed_with(server.uri, [])
            assert code == 1013 and "full" in reason
        deadline = time.monotonic() + 10
        while server.server.sessions and time.monotonic() < deadline:  # disconnected clients free theirs
            time.sleep(0.01)
        assert not server.server.sessions
        with connect(server.uri) as socket:
            for _ in range(60):
                socket.send('{"type": "clock"}')
            codes = []
            with pytest.raises(ConnectionClosed) as closed:
                while True:
                    message = json.loads(socket.recv(timeout=30))
                    codes.append(message.get("code"))
            assert "flood" in codes and closed.value.rcvd is not None and closed.value.rcvd.code == 1008
        with Client(server.uri, clock="script") as client:  # still serving
            assert list(client.send({"type": "clock"})) == [{"type": "clock", "t": 0.0}]


@pytest.mark.slow
def test_a_client_that_does_not_read_is_closed() -> None:
    with BackgroundServer(write_limit=2000, send_timeout=0.5) as server, connect(server.uri, max_size=None) as socket:
        socket.send(json.dumps({"type": "hello", "clock": "script", "keep": True}))
        socket.send(json.dumps({"t": 0, "emotion": "tension", "until": 600}))
        for _ in range(150):  # a growing answer each, never read
            socket.send('{"type": "timeline"}')
            time.sleep(0.005)
            if not server.server.sessions:
                break
        deadline = time.monotonic() + 20
        while server.server.sessions and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not server.server.sessions  # closed (1008) and freed


def _serve(*args: str) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-m", "mse", "serve", "--port", "0", *args], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signals_shut_it_down_cleanly(signum: int) -> None:
    process = _serve()
    try:
        assert process.stdout is not None
        line = process.stdout.readline()
        match = re.search(r"ws://127\.0\.0\.1:(\d+)/", line)
        assert match, line
        with Client(f"ws://127.0.0.1:{match.group(1)}/", clock="script") as client:
            assert any(m["type"] == "occurrence" for m in list(client.send({"t": 0, "emotion": "anger"})))
            process.send_signal(signum)
            with pytest.raises(ConnectionClosed):
                client._socket.recv(timeout=30)
        _, err = process.communicate(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 0, err
    assert "Traceback" not in err


@pytest.mark.slow
def test_bad_options_and_a_taken_port_exit_1() -> None:
    for args in (["--max-sessions", "0"], ["--port", "70000"]):
        done = subprocess.run([sys.executable, "-m", "mse", "serve", *args], cwd=ROOT, capture_output=True, text=True,
                              env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=60)
        assert done.returncode == 1 and "E130" in done.stderr and "Traceback" not in done.stderr
    with BackgroundServer() as server:
        done = subprocess.run([sys.executable, "-m", "mse", "serve", "--port", str(server.server.port)], cwd=ROOT,
                              capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=60)
        assert done.returncode == 1 and "cannot listen" in done.stderr and "Traceback" not in done.stderr


def test_the_docs_client_runs(server: BackgroundServer) -> None:
    text = (ROOT / "docs" / "serve.md").read_text(encoding="utf-8")
    (code,) = re.findall(r"```python\n(.*?)```", text, re.S)
    code = code.replace("ws://127.0.0.1:8765/", server.uri)
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr
    assert "occurrence" in done.stdout and "episode 0 anger" in done.stdout


@pytest.mark.slow
def test_on_the_real_clock_an_episode_goes_on_without_events() -> None:
    with BackgroundServer() as server, connect(server.uri, max_size=None) as socket:
        socket.send(json.dumps({"type": "hello", "seed": 2}))
        socket.send(json.dumps({"emotion": "tension", "until": 0.5}))
        episodes: list[dict[str, Any]] = []
        deadline = time.monotonic() + 20
        while len(episodes) < 2 and time.monotonic() < deadline:  # continued a LEAD (1 s) before its plan ends
            message = json.loads(socket.recv(timeout=20))
            if message["type"] == "episode":
                episodes.append(message)
        assert [(e["index"], e["stop"]) for e in episodes] == [(0, 0.5), (1, 10.5)]
        assert episodes[1].get("continues") and not episodes[1]["interrupted"]
