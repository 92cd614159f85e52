"""The WebSocket server of ``mse serve`` on the ``websockets`` library (the ``serve`` extra).

Each connection is one :class:`~mse.serve.protocol.Connection`.  The service's limits
(docs/serve.md): at most ``max_sessions`` connections (one more is closed with 1013, try again
later); a message larger than ``max_message`` bytes closes the connection with 1009; at most
``max_queue`` messages wait unread per connection (then the socket stops reading: TCP pushes back
on the client); a client that does not read what it is sent for :data:`SEND_TIMEOUT` seconds, or
whose unread output passes ``write_limit`` bytes, is closed with 1008, so a slow client cannot grow
the server's memory; a client that sends more than ``max_rate`` messages a second gets an error
for each extra one (the message is dropped), and past twice that it is closed with 1008.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import json
import signal
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from html import escape
from http import HTTPStatus
from importlib import resources
from typing import TYPE_CHECKING, Any

from mse.extras import require
from mse.serve.protocol import Connection, Options, error_message

if TYPE_CHECKING:
    from websockets.asyncio.server import Server, ServerConnection
    from websockets.http11 import Request, Response

#: On the real clock, an episode that runs on past its plan (no event came) is continued this
#: many seconds before its plan ends, checked every :data:`TICK` seconds.
LEAD = 1.0
TICK = 0.25
#: Seconds a message out may wait for the client to read before the connection is closed (1008).
SEND_TIMEOUT = 5.0


@functools.cache
def live_page() -> str:
    """The live page: a button per bundled emotion, a sentence to say, the face as it plays."""
    from mse.resources import bundled_names

    buttons = "".join(f'<button type="button" data-emotion="{escape(name)}">{escape(name)}</button>'
                      for name in bundled_names())
    page = resources.files("mse.serve").joinpath("page.html").read_text(encoding="utf-8")
    return page.replace("<!--EMOTIONS-->", buttons)


@dataclass(frozen=True, slots=True)
class Limits:
    """The service's limits (``mse serve`` options)."""

    max_sessions: int = 100
    max_message: int = 64 * 1024
    max_queue: int = 16
    max_rate: float = 200.0
    write_limit: int = 1024 * 1024
    send_timeout: float = SEND_TIMEOUT


@dataclass
class _Bucket:
    """Messages a second, with a burst of one second's worth."""

    rate: float
    tokens: float
    stamp: float = field(default_factory=time.monotonic)
    excess: float = 0.0

    def take(self) -> bool:
        now = time.monotonic()
        self.tokens = min(self.rate, self.tokens + (now - self.stamp) * self.rate)
        self.excess = max(0.0, self.excess - (now - self.stamp) * self.rate)
        self.stamp = now
        if self.tokens >= 1.0:
            self.tokens -= 1.0
            return True
        self.excess += 1.0
        return False


class _Closing(Exception):
    def __init__(self, code: int, reason: str) -> None:
        super().__init__(reason)
        self.code = code
        self.reason = reason


class MseServer:
    """The sessions of one server: ``await start()`` listens; ``port`` is the bound port."""

    def __init__(self, host: str = "127.0.0.1", port: int = 8765, *, options: Options | None = None,
                 limits: Limits | None = None, log: Callable[[str], None] | None = None) -> None:
        self.host = host
        self.port = port
        self.options = options or Options()
        self.limits = limits or Limits()
        self.sessions: dict[str, Connection] = {}
        self._log = log or (lambda line: None)
        self._count = 0
        self._server: Server | None = None

    async def start(self) -> None:
        with require("serve"):
            from websockets.asyncio.server import serve
        self._server = await serve(
            self._handler, self.host, self.port, max_size=self.limits.max_message, max_queue=self.limits.max_queue,
            write_limit=self.limits.write_limit, compression=None, process_request=self._process_request,
        )
        self.port = self._server.sockets[0].getsockname()[1] if self._server.sockets else self.port

    async def close(self) -> None:
        if self._server is not None:
            self._server.close(close_connections=True)
            await self._server.wait_closed()

    def _process_request(self, connection: ServerConnection, request: Request) -> Response | None:
        """Plain HTTP on the same port: ``GET /`` is the live page, anything else not found."""
        if request.headers.get("Upgrade", "").lower() == "websocket":
            return None
        if request.path.partition("?")[0] != "/":
            return connection.respond(HTTPStatus.NOT_FOUND, "not found: the live page is at /\n")
        response = connection.respond(HTTPStatus.OK, live_page())
        del response.headers["Content-Type"]
        response.headers["Content-Type"] = "text/html; charset=utf-8"
        return response

    async def _handler(self, websocket: ServerConnection) -> None:
        with require("serve"):
            from websockets.exceptions import ConnectionClosed
        if len(self.sessions) >= self.limits.max_sessions:
            await websocket.close(1013, f"server full ({self.limits.max_sessions} sessions): try again later")
            return
        self._count += 1
        name = f"s{self._count}"
        connection = Connection(name, self.options, time.monotonic)
        self.sessions[name] = connection
        bucket = _Bucket(self.limits.max_rate, self.limits.max_rate)
        self._log(f"{name}: open ({len(self.sessions)} sessions)")
        turn = asyncio.Lock()  # one message, or one tick, at a time
        ticker = asyncio.create_task(self._tick(websocket, connection, turn))
        try:
            async for message in websocket:
                if not bucket.take():
                    if bucket.excess > self.limits.max_rate:
                        raise _Closing(1008, f"flood: more than {self.limits.max_rate:g} messages a second")
                    await self._send(websocket, error_message(
                        "flood", f"more than {self.limits.max_rate:g} messages a second: message dropped"))
                    continue
                async with turn:
                    for out in connection.handle(message):
                        await self._send(websocket, out)
        except _Closing as closing:
            with contextlib.suppress(ConnectionClosed):
                await asyncio.wait_for(websocket.close(closing.code, closing.reason), self.limits.send_timeout)
        except ConnectionClosed:
            pass
        finally:
            ticker.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await ticker
            del self.sessions[name]
            self._log(f"{name}: closed ({len(self.sessions)} sessions)")

    async def _tick(self, websocket: ServerConnection, connection: Connection, turn: asyncio.Lock) -> None:
        """Continue a running episode on the real clock before its plan runs out."""
        with require("serve"):
            from websockets.exceptions import ConnectionClosed
        try:
            while True:
                await asyncio.sleep(TICK)
                async with turn:
                    for out in connection.tick(LEAD):
                        await self._send(websocket, out)
        except _Closing as closing:
            with contextlib.suppress(ConnectionClosed, TimeoutError):
                await asyncio.wait_for(websocket.close(closing.code, closing.reason), self.limits.send_timeout)
        except ConnectionClosed:
            pass

    async def _send(self, websocket: ServerConnection, message: dict[str, Any]) -> None:
        transport = websocket.transport
        if transport is not None and transport.get_write_buffer_size() > self.limits.write_limit:
            raise _Closing(1008, "the client does not read what it is sent")
        try:
            await asyncio.wait_for(websocket.send(json.dumps(message)), self.limits.send_timeout)
        except TimeoutError:
            raise _Closing(1008, "the client does not read what it is sent") from None
        await asyncio.sleep(0)  # the other sessions run between two occurrences


async def run_until_signalled(server: MseServer, ready: Callable[[MseServer], None] | None = None) -> None:
    """Serve until SIGINT or SIGTERM, then close every connection (1001) and return."""
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(signum, stop.set)
    await server.start()
    if ready is not None:
        ready(server)
    try:
        await stop.wait()
    finally:
        for signum in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(signum)
        await server.close()


def serve_forever(server: MseServer, ready: Callable[[MseServer], None] | None = None) -> None:
    asyncio.run(run_until_signalled(server, ready))


__all__ = ["LEAD", "SEND_TIMEOUT", "TICK", "Limits", "MseServer", "run_until_signalled", "serve_forever"]
