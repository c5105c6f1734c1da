"""The page and its static files, served from a fixed table (never by a client-given path)."""

from __future__ import annotations

from importlib import resources

from fastapi import APIRouter, HTTPException
from fastapi.responses import HTMLResponse, Response

STATIC = {
    "index.html": "text/html",
    "app.js": "text/javascript",
    "addphoto.js": "text/javascript",
    "navigate.js": "text/javascript",
    "live.js": "text/javascript",
    "calibrate.js": "text/javascript",
    "style.css": "text/css",
}

router = APIRouter()


def _static(name: str) -> bytes:
    return resources.files("mrcheck.apps.review").joinpath("static", name).read_bytes()


@router.get("/", response_class=HTMLResponse)
def index():
    return HTMLResponse(_static("index.html"))


@router.get("/favicon.ico")
def favicon():  # what every browser asks for: no icon, rather than a 404 in its console on every load
    return Response(status_code=204)


@router.get("/static/{name}")
def static(name: str):
    if name not in STATIC:
        raise HTTPException(404, "not found")
    return Response(_static(name), media_type=STATIC[name])
