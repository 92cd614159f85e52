"""``mse serve``: dialogue sessions over WebSocket (docs/serve.md).

:mod:`mse.serve.protocol` is the protocol without a network: one :class:`~mse.serve.protocol.Connection`
per client turns each message in into the messages out (a :class:`~mse.dialogue.Session` behind it);
:mod:`mse.serve.server` runs connections on the ``websockets`` library (the ``serve`` extra) with
the service's limits; :mod:`mse.serve.client` is a small client.
"""
