"""A small client of ``mse serve`` (docs/serve.md): send an event, read what it commits.

>>> from mse.serve.client import Client                             # doctest: +SKIP
>>> with Client("ws://127.0.0.1:8765/", clock="script", seed=1) as client:   # doctest: +SKIP
...     for message in client.send({"t": 0, "emotion": "joy"}):
...         print(message["type"], message.get("lexeme"))
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator
from types import TracebackType
from typing import Any

from mse.extras import require


class Client:
    """One session: ``hello`` with the options given, then :meth:`send` per message."""

    def __init__(self, uri: str, *, timeout: float = 30.0, **hello: Any) -> None:
        with require("serve"):
            from websockets.sync.client import connect
        self.timeout = timeout
        self._stack = contextlib.ExitStack()
        self._socket = self._stack.enter_context(connect(uri, open_timeout=timeout, max_size=None))
        self.hello: dict[str, Any] = {}
        if hello:
            answer = list(self.send({"type": "hello", "protocol": 1, **hello}))
            self.hello = answer[0]

    def send(self, message: dict[str, Any] | str) -> Iterator[dict[str, Any]]:
        """Send ``message``; the messages out it brings, each as it arrives, up to its ``ack``
        or ``error`` (not yielded when it is an ack)."""
        self._socket.send(message if isinstance(message, str) else json.dumps(message))
        while True:
            out = json.loads(self._socket.recv(timeout=self.timeout))
            if out["type"] == "ack":
                return
            yield out
            if out["type"] == "error":
                return

    def close(self) -> None:
        self._stack.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None,
                 trace: TracebackType | None) -> None:
        self.close()
