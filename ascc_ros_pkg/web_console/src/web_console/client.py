"""A blocking WebSocket client of the console (tornado's, on its own IOLoop thread), for
the rostests and the benchmark: a script talks to the node as a page does."""
from __future__ import annotations

import asyncio
import json
import threading
import time
from typing import Any, List, Optional

from tornado import websocket

from web_console.protocol import split_frame


class ConsoleClient:
    """Connects to ``ws://host:port/ws``; every received message is kept with its
    arrival time (``time.monotonic()``): ``texts`` (parsed JSON) and ``frames`` (kind,
    header, payload) (``keep_payload=False`` keeps only the payload's length)."""

    def __init__(self, url: str, timeout_s: float = 10.0, keep_payload: bool = True):
        self.url, self.keep_payload = url, keep_payload
        self.texts: List[Any] = []
        self.frames: List[Any] = []
        self.closed = False
        self.lock = threading.Lock()
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        self.conn = self._run(lambda: websocket.websocket_connect(
            url, max_message_size=2 ** 24), timeout_s)
        asyncio.run_coroutine_threadsafe(self._read(), self.loop)

    def _run(self, make, timeout_s):
        async def wrap():  # the future is made on the client's loop
            return await make()
        return asyncio.run_coroutine_threadsafe(wrap(), self.loop).result(timeout_s)

    async def _read(self):
        while True:
            msg = await self.conn.read_message()
            now = time.monotonic()
            if msg is None:
                self.closed = True
                return
            with self.lock:
                if isinstance(msg, bytes):
                    kind, header, payload = split_frame(msg)
                    self.frames.append((now, kind, header,
                                        payload if self.keep_payload else len(payload)))
                else:
                    self.texts.append((now, json.loads(msg)))

    def send(self, obj: Any) -> None:
        """Send ``obj`` as JSON (a str is sent as it is)."""
        text = obj if isinstance(obj, str) else json.dumps(obj)
        self.loop.call_soon_threadsafe(self.conn.write_message, text)

    def send_binary(self, data: bytes) -> None:
        self.loop.call_soon_threadsafe(self.conn.write_message, data, True)

    def messages(self, kind: str) -> List[Any]:
        with self.lock:
            return [m for _, m in self.texts if m.get("type") == kind]

    def wait(self, predicate, timeout_s: float) -> Optional[Any]:
        """The first value of ``predicate(self)`` that is truthy within ``timeout_s``."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            value = predicate(self)
            if value:
                return value
            time.sleep(0.01)
        return None

    def close(self) -> None:
        self.loop.call_soon_threadsafe(self.conn.close)
        time.sleep(0.05)
        self.loop.call_soon_threadsafe(self.loop.stop)
