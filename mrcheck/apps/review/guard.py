"""The review server's limits on requests: the Host they name, the site they come from and the
size of their body, checked by :class:`RequestCheck` (pure ASGI) in front of the token check and
every route.

* **Host**: a request must name this server in its Host header (:func:`host_names`), else 403.
  Without it, DNS rebinding lets a page on another site read the review: its name is made to
  resolve to 127.0.0.1, the browser then sends the page's requests to this server and lets the
  page read the answers (same origin), with ``Host: attacker.example``. A browser always sends
  the name of the URL it opened, so an IP literal never comes from a rebound name.
* **Site**: a request that changes state from another site's page is 403
  (:func:`.crosssite.cross_site_problem`).
* **Body size**: a Content-Length over the limit is a 413 before anything is read or any route
  runs; a chunked body is counted as it is read (Starlette's RequestBodyLimitMiddleware, which
  FastAPI's ``max_body_size`` is made of) and refused with 413 once it passes the limit, the
  rest unread. The largest body the app takes is a marker with the longest note, some 26 kB
  (2000 characters, JSON-escaped as 12 bytes each at worst). The exceptions are the files
  uploaded (:data:`UPLOAD_PATHS`): a photo or camera file of "Add photo", and a BCF file to
  import (the review's own export of 16 markers is some 1.5 MB, another tool's with full-size
  snapshots more), limited to ``max_upload``; a BCF file is bounded again, unpacked, by
  :mod:`mrcheck.apps.bcf.archive`.
"""

from __future__ import annotations

import ipaddress
import re
import socket
from dataclasses import dataclass

from fastapi.responses import JSONResponse
from starlette.datastructures import Headers
from starlette.middleware.body_limit import RequestBodyLimitMiddleware
from starlette.websockets import WebSocketClose

from mrcheck.apps.review.crosssite import WEBSOCKET, cross_site_problem

MAX_BODY = 1 << 20  # the default limit: 1 MiB, some 40 x the largest marker
MIN_MAX_BODY = 64 << 10  # a smaller limit would refuse markers with long notes
MAX_UPLOAD = 64 << 20  # an uploaded photo: a 24 MP JPEG is some 12 MB, a 16-bit TIFF more
UPLOAD_PATH = "/api/addphoto/upload"
BCF_IMPORT_PATH = "/api/bcf/import"
UPLOAD_PATHS = (UPLOAD_PATH, BCF_IMPORT_PATH)  # bodies limited to max_upload, not max_body
ALL_INTERFACES = ("0.0.0.0", "::", "")
LOOPBACK_NAMES = ("localhost", "127.0.0.1", "[::1]")
_HOST = re.compile(r"(?P<name>\[[0-9a-f:.]+\]|[a-z0-9_.-]+)(?::[0-9]{1,5})?")
_SIZE = re.compile(r"(?P<number>[0-9]+)\s*(?:(?P<unit>[kmg])i?b?|b?)")


@dataclass(frozen=True)
class Hosts:
    """The names a request may give in its Host header (lower case, IPv6 in brackets, any port:
    an SSH tunnel or a proxy puts its own port there)."""

    names: frozenset
    any_address: bool = False  # bound to every interface: any IP literal (of this machine) too

    def allows(self, name: str) -> bool:
        return name in self.names or (self.any_address and _is_address(name))

    def describe(self) -> str:
        shown = sorted(self.names)
        return ", ".join((["this machine's addresses"] if self.any_address else []) + shown)


def is_loopback(host: str) -> bool:
    """A bind address only this machine reaches: localhost, 127.0.0.0/8, ::1 (not a name that
    merely starts with "127.")."""
    if host.lower().rstrip(".") == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def host_names(bound: str) -> Hosts:
    """What a request to a server bound to ``bound`` (``--host``) may name: on loopback, the bound
    address, localhost, 127.0.0.1 and [::1]; on every interface (0.0.0.0, ::), also the machine's
    name (what the printed URL carries), its full name and its addresses; on another address,
    that address and the machine's names."""
    own = _host_name(bound)
    if is_loopback(bound):
        return Hosts(frozenset({own, *LOOPBACK_NAMES}))
    machine = machine_names()
    if bound in ALL_INTERFACES:
        return Hosts(frozenset({*LOOPBACK_NAMES, *machine}), any_address=True)
    return Hosts(frozenset({own, *machine}))


def machine_names() -> set[str]:
    """This machine's name and full name, lower case."""
    return {n.lower().rstrip(".") for n in (socket.gethostname(), socket.getfqdn()) if n}


def _host_name(host: str) -> str:
    """``host`` as a Host header gives it: lower case, an IPv6 address compressed, in brackets."""
    host = host.strip().lower().rstrip(".")
    try:
        address = ipaddress.ip_address(host.strip("[]"))
    except ValueError:
        return host
    return f"[{address.compressed}]" if address.version == 6 else address.compressed


def _is_address(name: str) -> bool:
    try:
        address = ipaddress.ip_address(name.strip("[]"))
    except ValueError:
        return False
    return (address.version == 6) == name.startswith("[")


def _parse_host(header: str | None) -> str | None:
    """The host of a Host header (:func:`_host_name` form), or None when it is missing or malformed."""
    match = _HOST.fullmatch((header or "").strip().lower())
    if match is None:
        return None
    name = match["name"]
    if name.startswith("[") and not _is_address(name):
        return None
    return _host_name(name)


class RequestCheck:
    """In front of the app: 403 for a Host header not in ``hosts`` (None: no Host check) or a
    state-changing request from another site (:mod:`.crosssite`), 413 for a
    Content-Length over ``max_body``, before the body is read or any route runs; a body without
    one is counted as it is read, by Starlette's RequestBodyLimitMiddleware behind this check
    (whose own answer to a declared size is a plain-text 413, not the app's JSON error)."""

    def __init__(self, app, hosts: Hosts | None, max_body: int, max_upload: int = MAX_UPLOAD):
        self.app = RequestBodyLimitMiddleware(app, max_body_size=max_body)
        self.upload_app = RequestBodyLimitMiddleware(app, max_body_size=max_upload)
        self.hosts, self.max_body, self.max_upload = hosts, max_body, max_upload

    async def __call__(self, scope, receive, send):
        upload = scope["type"] == "http" and scope.get("path") in UPLOAD_PATHS
        if scope["type"] == "http":
            refused = self._refused(Headers(scope=scope), upload, scope.get("method", "GET"))
            if refused is not None:
                return await JSONResponse({"error": refused[1]}, status_code=refused[0])(scope, receive, send)
        if scope["type"] == "websocket":  # the render session: the same Host and other-site checks
            refused = self._refused(Headers(scope=scope), False, WEBSOCKET)
            if refused is not None:
                return await WebSocketClose(code=1008, reason=refused[1][:120])(scope, receive, send)
        await (self.upload_app if upload else self.app)(scope, receive, send)

    def _refused(self, headers, upload: bool, method: str) -> tuple[int, str] | None:
        if self.hosts is not None:
            given = headers.get("host")
            name = _parse_host(given)
            if name is None or not self.hosts.allows(name):
                what = "no Host header" if given is None else f"Host {given!r} is not a name of this server"
                return 403, f"{what} (it answers to {self.hosts.describe()})"
        if problem := cross_site_problem(method, headers):
            return 403, problem
        length = headers.get("content-length")
        limit = self.max_upload if upload else self.max_body
        if length is not None and length.isdigit() and int(length) > limit:
            return 413, too_large(limit, f"{int(length)} bytes, ", "--max-upload" if upload else "--max-body")
        return None


def too_large(limit: int, size: str = "", option: str = "--max-body") -> str:
    return f"request body too large: {size}over the limit of {format_size(limit)} ({option})"


def parse_size(text: str) -> int:
    """Bytes of a size such as ``1MiB``, ``64KiB``, ``2M`` or ``1048576`` (K, M, G are binary);
    ValueError saying what is wrong."""
    match = _SIZE.fullmatch(str(text).strip().lower())
    if match is None:
        raise ValueError(f"{text!r} is not a size (e.g. 1MiB, 512KiB or a number of bytes)")
    return int(match["number"]) << {None: 0, "k": 10, "m": 20, "g": 30}[match["unit"]]


def format_size(size: int) -> str:
    for shift, unit in ((30, "GiB"), (20, "MiB"), (10, "KiB")):
        if size >= 1 << shift and size % (1 << shift) == 0:
            return f"{size >> shift} {unit}"
    return f"{size} bytes"
