"""A WebSocket whose requests supersede each other: the render session's cameras and the live
session's video frames (:mod:`.viewsession`, :mod:`.livesession`). Messages are read as they
come; while one request is worked on, a newer one replaces the one waiting, so a page that sends
faster than the server answers never builds a queue, and every answer is to the newest request
then known. A request that cannot be parsed is answered with ``{"type": "error", "error"}`` and
the session goes on; so is one whose work fails.
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import Callable

from starlette.websockets import WebSocketDisconnect

MAX_TEXT = 4096  # characters of a text message: a camera and a few names
MAX_BYTES = 8 << 20  # bytes of a binary message: a JPEG video frame (the live session)


class NewestOnly:
    """``parse(message)`` -> a request, None (a message that needs no answer) or ValueError;
    ``message`` is ``{"text": str}`` or ``{"bytes": bytes}``. ``work(request)`` -> (a JSON-able
    header, bytes or None), run on a worker thread; both are sent, the header first."""

    def __init__(self, parse: Callable, work: Callable):
        self.parse, self.work = parse, work
        self.latest = None
        self.wake = asyncio.Event()
        self.closed = False

    async def serve(self, websocket) -> None:
        reader = asyncio.create_task(self._read(websocket))
        loop = asyncio.get_running_loop()
        try:
            while not self.closed:
                await self.wake.wait()
                self.wake.clear()
                request, self.latest = self.latest, None
                if request is None:
                    continue
                try:
                    header, data = await loop.run_in_executor(None, self.work, request)
                except Exception as exc:  # noqa: BLE001 -- a request that fails is answered, the session goes on
                    header, data = {"type": "error", "error": str(exc)}, None
                await websocket.send_json(header)
                if data is not None:
                    await websocket.send_bytes(data)
        except (WebSocketDisconnect, RuntimeError):  # the page went away while its answer was worked on
            pass
        finally:
            reader.cancel()

    async def _read(self, websocket) -> None:
        try:
            while True:
                message = await websocket.receive()
                if message["type"] == "websocket.disconnect":
                    break
                try:
                    request = self.parse(_checked(message))
                except ValueError as exc:
                    await websocket.send_json({"type": "error", "error": str(exc)})
                    continue
                if request is not None:
                    self.latest = request
                    self.wake.set()
        except RuntimeError:  # the socket went away between two reads
            pass
        finally:
            self.closed = True
            self.wake.set()


def json_message(text: str):
    """The JSON value of a text message; ValueError (answered to the page) when it is none."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"not JSON: {exc.msg}") from None


def _checked(message: dict) -> dict:
    text, data = message.get("text"), message.get("bytes")
    if text is not None:
        if len(text) > MAX_TEXT:
            raise ValueError(f"a text message is at most {MAX_TEXT} characters")
        return {"text": text}
    if data is None or len(data) > MAX_BYTES:
        raise ValueError(f"a binary message is at most {MAX_BYTES >> 20} MiB")
    return {"bytes": data}


__all__ = ["NewestOnly", "json_message", "MAX_TEXT", "MAX_BYTES"]
