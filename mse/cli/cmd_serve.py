"""``mse serve``: dialogue sessions over WebSocket, one per connection (docs/serve.md)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from mse.diagnostics import argument_error


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "serve",
        help="plan dialogues live: a WebSocket server, one dialogue session per connection",
        description="Serve dialogue sessions over WebSocket (protocol 1; JSON Schema: mse/serve/protocol.schema.json): "
        "send events "
        "({\"emotion\": \"joy\"}, {\"say\": \"...\"}, {\"end\": true}), receive the occurrences as they are "
        "committed. Listens on 127.0.0.1 unless --host says otherwise; SIGINT or SIGTERM stop it (exit 0).",
    )
    parser.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    parser.add_argument("--port", type=int, default=8765, help="port (default 8765; 0: a free one, printed)")
    parser.add_argument("--max-sessions", type=int, default=100,
                        help="sessions at once; one more is closed with 1013 (default 100)")
    parser.add_argument("--max-message", type=int, default=65536, metavar="BYTES",
                        help="largest message in; a larger one closes the connection with 1009 (default 65536)")
    parser.add_argument("--max-rate", type=float, default=200.0,
                        help="messages a second per session; extra ones are dropped with an error (default 200)")
    parser.add_argument("--clock", choices=("real", "script"), default="real",
                        help="session clock by default: real (wall time from the first event) or script "
                        "(event times drive it); a client's hello may choose")
    parser.add_argument("--seed", type=int, default=0, help="planner seed by default (a client's hello may choose)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no log of connections on stderr")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from mse.cli.common import print_error
    from mse.diagnostics import MseError
    from mse.serve.protocol import Options
    from mse.serve.server import Limits, MseServer, serve_forever

    try:
        if not 0 <= args.port <= 65535:
            raise argument_error(f"--port {args.port} is not a port (0 to 65535)")
        for name in ("max_sessions", "max_message", "max_rate"):
            if not getattr(args, name) > 0:
                raise argument_error(f"--{name.replace('_', '-')} must be positive")
        if not 0 <= args.seed < 2**31:
            raise argument_error("--seed must be in [0, 2^31)")
    except MseError as error:
        return print_error(error)
    log = None if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))
    server = MseServer(args.host, args.port, options=Options(seed=args.seed, clock=args.clock),
                       limits=Limits(max_sessions=args.max_sessions, max_message=args.max_message,
                                     max_rate=args.max_rate), log=log)

    def ready(started: MseServer) -> None:
        print(f"mse serve: ws://{started.host}:{started.port}/ (protocol 1)", flush=True)

    try:
        serve_forever(server, ready)
    except OSError as error:  # the port is taken, the address is not ours
        print(f"error: cannot listen on {args.host}:{args.port}: {error.strerror or error}", file=sys.stderr)
        return 1
    return 0
