"""``mse study serve``: the study folder over HTTP (the standard library's threading
server, for a study run on one machine or a local network), and ``POST
/results/<participant>`` storing each participant's CSV in ``results/`` (written
atomically, checked first, never replacing one already stored).  A bad request gets a
4xx answer with a one-line reason; the server keeps serving."""

from __future__ import annotations

import http.server
import sys
from functools import partial
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urlsplit

from mse.study.results import PARTICIPANT_ID, BadResults, check_results

#: Largest upload accepted (a results CSV of thousands of answers is far smaller).
MAX_UPLOAD = 1 << 20


class StudyHandler(http.server.SimpleHTTPRequestHandler):
    """Files of the study folder (never ``results/``), and result uploads."""

    manifest: dict[str, Any]
    folder: Path

    def __init__(self, *args: Any, folder: Path, manifest: dict[str, Any], **kwargs: Any) -> None:
        self.folder = folder
        self.manifest = manifest
        super().__init__(*args, directory=str(folder), **kwargs)

    def log_message(self, format: str, *args: Any) -> None:
        """Quiet: the server reports stored results, not every file served."""

    def _reply(self, status: int, message: str) -> None:
        body = (message + "\n").encode("utf-8")
        self.send_response(status)
        self.send_header("Content-Type", "text/plain; charset=utf-8")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def _private(self) -> bool:
        path = unquote(urlsplit(self.path).path)
        return path.strip("/").split("/")[0] == "results"

    def do_GET(self) -> None:
        if self._private():
            self._reply(403, "results are not served")
            return
        super().do_GET()

    def do_HEAD(self) -> None:
        if self._private():
            self._reply(403, "results are not served")
            return
        super().do_HEAD()

    def do_POST(self) -> None:
        parts = unquote(urlsplit(self.path).path).strip("/").split("/")
        if len(parts) != 2 or parts[0] != "results":
            self._reply(404, "POST results/<participant>")
            return
        participant = parts[1]
        if PARTICIPANT_ID.fullmatch(participant) is None:
            self._reply(400, "a participant id is 1-64 letters, digits, - or _")
            return
        known = {p["id"] for p in self.manifest["participants"]}
        if participant not in known:
            self._reply(400, f"no participant {participant!r} in this study")
            return
        length_text = self.headers.get("Content-Length")
        if length_text is None or not length_text.isdigit():
            self._reply(411, "a Content-Length is needed")
            return
        length = int(length_text)
        if length > MAX_UPLOAD:
            self._reply(413, f"at most {MAX_UPLOAD} bytes")
            return
        data = self.rfile.read(length)
        if len(data) != length:
            self._reply(400, "the body is shorter than its Content-Length")
            return
        try:
            count = check_results(data.decode("utf-8"), participant, self.manifest)
        except UnicodeDecodeError:
            self._reply(400, "the body is not UTF-8")
            return
        except BadResults as error:
            self._reply(400, f"not a results CSV of this study: {error}")
            return
        status, message = store(self.folder, participant, data)
        if status == 200:
            print(f"stored results/{participant}.csv ({count} answers)", file=sys.stderr, flush=True)
        self._reply(status, message)


def store(folder: Path, participant: str, data: bytes) -> tuple[int, str]:
    """Write ``results/<participant>.csv`` atomically unless it exists (409)."""
    import os
    import tempfile

    target = folder / "results" / f"{participant}.csv"
    try:
        target.parent.mkdir(exist_ok=True)
        handle, temporary = tempfile.mkstemp(prefix=f".{participant}.", suffix=".tmp", dir=target.parent)
        try:
            with os.fdopen(handle, "wb") as out:
                out.write(data)
                out.flush()
                os.fsync(out.fileno())
            os.link(temporary, target)  # fails when the participant's results exist: never replaced
        finally:
            os.unlink(temporary)
    except FileExistsError:
        return 409, f"results of {participant} are already stored"
    except OSError as error:
        return 500, f"cannot store the results: {error.strerror or error}"
    return 200, f"stored results/{participant}.csv"


class StudyServer(http.server.ThreadingHTTPServer):
    daemon_threads = True

    def handle_error(self, request: Any, client_address: Any) -> None:
        """A client that breaks off is its own problem: one line, no traceback."""
        error = sys.exc_info()[1]
        print(f"mse study serve: request from {client_address[0]} failed: {error}", file=sys.stderr, flush=True)


def make_server(folder: Path, manifest: dict[str, Any], host: str, port: int) -> StudyServer:
    handler = partial(StudyHandler, folder=folder, manifest=manifest)
    return StudyServer((host, port), handler)
