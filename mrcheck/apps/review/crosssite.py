"""Requests from other sites' pages change nothing. A browser lets any page send a "simple"
request to this server without asking it first (no CORS preflight): a POST of
``text/plain``, ``multipart/form-data`` or ``application/x-www-form-urlencoded``. The page cannot
read the answer, but the request would still change markers. Two checks stop that:

* **Origin** (:func:`cross_site_problem`, in :class:`.guard.RequestCheck` before any route): a
  request that changes state (POST, PUT, PATCH, DELETE) is refused with 403 when the browser
  says it comes from another site (``Sec-Fetch-Site: cross-site`` or ``same-site``, i.e. another
  port or subdomain) or from another origin (an ``Origin`` header naming another host than the
  request's own ``Host``, or ``null``). Clients that are no browser (curl, scripts) send
  neither header and are let through: no page can make them send anything.
* **Content type** (:func:`requires`, a route dependency): the JSON routes take
  ``application/json`` only, the uploads (a photo, a camera file, a BCF file)
  ``application/octet-stream`` only, else 415. Neither is a type a page may send to another site
  without a preflight, which this server never grants (it answers no CORS), so even a browser
  that sends no Origin cannot deliver such a request. ``multipart/form-data`` is not taken for
  the same reason: any page's form can send it.
"""

from __future__ import annotations

from urllib.parse import urlsplit

from fastapi import HTTPException, Request

WEBSOCKET = "WEBSOCKET"  # a WebSocket handshake: a GET, but any page may open one to any server
UNSAFE_METHODS = frozenset({"POST", "PUT", "PATCH", "DELETE", WEBSOCKET})
JSON = "application/json"
OCTETS = "application/octet-stream"
FOREIGN_SITES = ("cross-site", "same-site")


def cross_site_problem(method: str, headers) -> str | None:
    """Why a state-changing request from another site's page is refused (see the module), or None."""
    if method.upper() not in UNSAFE_METHODS:
        return None
    site = (headers.get("sec-fetch-site") or "").strip().lower()
    if site in FOREIGN_SITES:
        return f"cross-site request refused (Sec-Fetch-Site: {site}): the review changes data from its own page only"
    origin = headers.get("origin")
    if origin is None:
        return None
    host = (headers.get("host") or "").strip().lower()
    if origin.strip().lower() == "null" or urlsplit(origin.strip().lower()).netloc != host:
        return (
            f"cross-site request refused (Origin {origin} is not this server, {host or 'no Host'}): "
            "the review changes data from its own page only"
        )
    return None


def requires(media_type: str):
    """A route dependency: the request's Content-Type is ``media_type`` (any parameters), else 415."""

    def check(request: Request) -> None:
        given = request.headers.get("content-type", "")
        if given.split(";")[0].strip().lower() != media_type:
            raise HTTPException(415, f"Content-Type must be {media_type} (got {given or 'none'})")

    return check


__all__ = ["cross_site_problem", "requires", "JSON", "OCTETS", "UNSAFE_METHODS", "WEBSOCKET"]
