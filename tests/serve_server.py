"""A real ``mse serve`` server on 127.0.0.1 (a free port) in a background thread, for the tests."""

from __future__ import annotations

import asyncio
import threading
from typing import Any

from mse.serve.protocol import Options
from mse.serve.server import Limits, MseServer


class BackgroundServer:
    """``with BackgroundServer(max_sessions=2) as server:`` then connect to ``server.uri``."""

    def __init__(self, options: Options | None = None, **limits: Any) -> None:
        self.server = MseServer("127.0.0.1", 0, options=options, limits=Limits(**limits))
        self.loop = asyncio.new_event_loop()
        self._started = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        asyncio.set_event_loop(self.loop)
        self.loop.run_until_complete(self.server.start())
        self._started.set()
        self.loop.run_forever()

    @property
    def uri(self) -> str:
        return f"ws://127.0.0.1:{self.server.port}/"

    def __enter__(self) -> BackgroundServer:
        self._thread.start()
        assert self._started.wait(30), "the server did not start"
        return self

    def __exit__(self, *exc: object) -> None:
        asyncio.run_coroutine_threadsafe(self.server.close(), self.loop).result(30)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self._thread.join(30)
        self.loop.close()
