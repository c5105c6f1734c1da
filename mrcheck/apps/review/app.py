"""The review web app: FastAPI routes over a Source, a Store, a RenderService and a Picker.

Files are served by shot name + kind only (never by a client-given path); static files from a
fixed table. Before anything else, a request must name this server in its Host header (else 403)
and its body must be within the limit (else 413), see :mod:`.guard`. With a token, every request
needs it (query ``token``, header ``X-Review-Token`` or the cookie set when the page is opened
with ``?token=``), else 401.
"""

from __future__ import annotations

import contextlib
import errno
import hmac
import os
import socket
import sys
import threading
import traceback
from importlib import resources
from pathlib import Path
from typing import Literal

from fastapi import FastAPI, HTTPException, Query, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse, Response
from pydantic import BaseModel, ConfigDict, Field
from starlette.exceptions import HTTPException as StarletteHTTPException

from mrcheck.apps.review.guard import (
    ALL_INTERFACES,
    MAX_BODY,
    MIN_MAX_BODY,
    RequestCheck,
    format_size,
    host_names,
    is_loopback,
    too_large,
)
from mrcheck.apps.review.renders import INTENSITIES, RenderService
from mrcheck.apps.review.report import markers_csv, report_html
from mrcheck.apps.review.storage import CATEGORIES, MAX_NOTE, Store
from mrcheck.apps.review.suggestions import pending
from mrcheck.core.errors import MrcheckError, bug_reason
from mrcheck.core.output import check_not_inputs
from mrcheck.render.renderer import MODES, STUDY_LABELS

STATIC = {"index.html": "text/html", "app.js": "text/javascript", "style.css": "text/css"}
KINDS = ("photo", "render", "edges", "thumb")
COOKIE = "mrcheck_review_token"
DATABASE, CACHE = "review.sqlite", ".review-cache"   # the defaults: in the source's home, the cache beside the database
MAX_ID = 2**63 - 1  # SQLite's INTEGER range; a larger id cannot be bound (OverflowError), nor exist

Category = Literal["missing", "moved", "extra", "wrong size", "other", "suggested"]
assert set(Category.__args__) == set(CATEGORIES)
Mode = Literal[MODES]
# strict: a field of the wrong type (a severity true or "2", a note null) or an unknown one (a
# typo such as "severty") is a 422, not converted or ignored; a whole number is still a valid x
_STRICT = ConfigDict(extra="forbid", strict=True)


class MarkerIn(BaseModel):
    model_config = _STRICT
    shot: str = Field(max_length=128)
    x: float
    y: float
    category: Category
    severity: int = Field(ge=1, le=3)
    note: str = Field(default="", max_length=MAX_NOTE)
    mode: Mode | None = None  # the mode the marker was placed in


class MarkerPatch(BaseModel):
    """Only the fields given are changed (the None defaults mean "not given"; null is refused)."""
    model_config = _STRICT
    x: float = None
    y: float = None
    category: Category = None
    severity: int = Field(default=None, ge=1, le=3)
    note: str = Field(default=None, max_length=MAX_NOTE)
    mode: Mode = None


def _static(name: str) -> bytes:
    return resources.files("mrcheck.apps.review").joinpath("static", name).read_bytes()


def database_path(source, db_path=None) -> Path:
    """The review database: ``--db``, else review.sqlite in the source's home."""
    return Path(db_path or source.home / DATABASE)


def create_app(source, db_path: Path | None = None, cache_dir: Path | None = None, token: str | None = None,
               samples: int = 16, suggestions: dict | None = None, host: str | None = None,
               max_body: int = MAX_BODY) -> FastAPI:
    """``suggestions``: {shot name: markers} (:func:`.suggestions.load_suggestions`), imported
    into the review's markers once; ``app.state.imported``: {shot name: markers added now}.
    ``host``: the address the server is bound to, whose names alone a request's Host header may
    give (:func:`.guard.host_names`); None checks no Host (an app not on a socket, as in tests).
    ``max_body``: the largest request body, in bytes."""
    db_path = database_path(source, db_path)
    store = Store(db_path, source.review_name(db_path),
                  served_scales={s.name: s.served_scale() for s in source.shots.values() if s.served_size != s.size})
    renders = RenderService(source, cache_dir or db_path.parent / CACHE, samples=samples)
    picker_lock = threading.Lock()
    picker_box: list = []

    def picker():
        with picker_lock:
            if not picker_box:
                from mrcheck.apps.review.pick import Picker
                picker_box.append(Picker(source.loaded))
            return picker_box[0]

    def cad_under(shot, x, y) -> dict:
        """What a marker at photo pixel (x, y) of ``shot`` stores of the CAD: its part instance and distance."""
        hit = picker().pick(shot.camera, x, y)
        return {"part": hit["instance"], "distance": hit["distance"]}

    imported = {}
    for name, markers in (suggestions or {}).items():
        # like a marker the planner places: the CAD part under it and its distance; only for the
        # new ones, so that a restart with nothing new does not load the scene for the picker
        shot = source.shots[name]
        markers = pending(markers, store.imported_keys(name), shot.size[0])
        cads = [cad_under(shot, m["x"], m["y"]) for m in markers]
        if added := store.import_suggestions(name, [{**m, **cad, "part": cad["part"] or m["part"]}
                                                    for m, cad in zip(markers, cads)]):
            imported[name] = added

    @contextlib.asynccontextmanager
    async def lifespan(app):
        yield
        renders.close()

    app = FastAPI(title="mrcheck review", docs_url=None, redoc_url=None, openapi_url=None, lifespan=lifespan)
    app.state.source, app.state.store, app.state.renders = source, store, renders
    app.state.imported = imported   # shot -> suggestions added at this start

    @app.exception_handler(RequestValidationError)
    async def _invalid(request, exc):
        errors = [f"{'.'.join(str(p) for p in e['loc'][1:]) or e['loc'][0]}: {e['msg']}" for e in exc.errors()]
        return JSONResponse({"error": "invalid input", "details": errors}, status_code=422)

    @app.exception_handler(StarletteHTTPException)  # the routing's own 404 / 405 too, not only ours
    async def _http(request, exc):
        # the body limit's own "Content Too Large" names neither the limit nor the option
        detail = too_large(max_body) if exc.status_code == 413 else exc.detail
        return JSONResponse({"error": detail}, status_code=exc.status_code, headers=exc.headers)

    @app.exception_handler(MrcheckError)
    async def _input_file(request, exc):
        # a shot's photo changed on disk after start-up (open_source checked them): 404 when it is
        # gone, else a server-side problem (a photo replaced by one of another size), not the client's
        gone = exc.path is not None and not Path(exc.path).exists()
        return JSONResponse({"error": str(exc)}, status_code=404 if gone else 500)

    @app.middleware("http")
    async def _token(request: Request, call_next):
        if token is None:
            return await call_next(request)
        given = request.query_params.get("token") or request.headers.get("x-review-token") or request.cookies.get(COOKIE)
        if not given or not hmac.compare_digest(given.encode(), token.encode()):
            return JSONResponse({"error": "a valid token is required (?token=...)"}, status_code=401)
        response = await call_next(request)
        if request.query_params.get("token"):
            response.set_cookie(COOKIE, token, httponly=True, samesite="strict")
        return response

    @app.middleware("http")   # the outermost: also what the token check might raise
    async def _unexpected(request: Request, call_next):
        try:
            return await call_next(request)
        except Exception as exc:  # a bug, not bad input: the API's error shape, one line on the console
            if os.environ.get("MRCHECK_DEBUG"):
                traceback.print_exc()
            reason = bug_reason(exc)
            print(f"error: internal error in {request.method} {request.url.path}, please report it: {reason}"
                  + ("" if os.environ.get("MRCHECK_DEBUG") else " (MRCHECK_DEBUG=1 shows the traceback)"),
                  file=sys.stderr, flush=True)
            return JSONResponse({"error": f"internal error, please report it: {reason}"}, status_code=500)

    # added last, so outermost: before the token check
    app.add_middleware(RequestCheck, hosts=None if host is None else host_names(host), max_body=max_body)

    def shot_or_404(name: str):
        if name not in source.shots:
            raise HTTPException(404, f"no shot named {name!r}")
        return source.shots[name]

    def marker_or_404(marker_id: int) -> dict:
        current = store.get(marker_id) if 1 <= marker_id <= MAX_ID else None
        if current is None:
            raise HTTPException(404, f"no marker {marker_id}")
        return current

    def check_marker_xy(shot, x, y):
        w, h = shot.size
        if not (0 <= x < w and 0 <= y < h):
            raise HTTPException(422, f"coordinates ({x}, {y}) are outside the {w}x{h} image")

    @app.get("/", response_class=HTMLResponse)
    def index():
        return HTMLResponse(_static("index.html"))

    @app.get("/favicon.ico")
    def favicon():  # what every browser asks for: no icon, rather than a 404 in its console on every load
        return Response(status_code=204)

    @app.get("/static/{name}")
    def static(name: str):
        if name not in STATIC:
            raise HTTPException(404, "not found")
        return Response(_static(name), media_type=STATIC[name])

    @app.get("/api/info")
    def info():
        return {"label": source.label, "modes": list(MODES), "labels": STUDY_LABELS, "intensities": list(INTENSITIES),
                "categories": list(CATEGORIES), "max_note": MAX_NOTE}

    @app.get("/api/shots")
    def shots():
        return [{"name": s.name, "error_px": s.error_px, "width": s.size[0], "height": s.size[1]}
                for s in source.shots.values()]

    @app.get("/api/shots/{name}/{kind}.png")
    def image(name: str, kind: str, mode: str = "phong", intensity: float = 1.0):
        shot_or_404(name)
        if kind not in KINDS:
            raise HTTPException(404, f"unknown image kind {kind!r} (use {', '.join(KINDS)})")
        if mode not in MODES:
            raise HTTPException(422, f"unknown mode {mode!r} (use {', '.join(MODES)})")
        if intensity not in INTENSITIES:
            raise HTTPException(422, f"intensity must be one of {', '.join(map(str, INTENSITIES))}")
        path = renders.file(name, kind, mode, intensity)
        return FileResponse(path, media_type="image/png", headers={"Cache-Control": "private, max-age=3600"})

    @app.get("/api/shots/{name}/pick")
    def pick(name: str, x: float = Query(...), y: float = Query(...)):
        shot = shot_or_404(name)
        check_marker_xy(shot, x, y)
        return picker().pick(shot.camera, x, y)

    @app.get("/api/markers")
    def list_markers(shot: str | None = None):
        if shot is not None:
            shot_or_404(shot)
        return store.markers(shot)

    @app.post("/api/markers", status_code=201)
    def add_marker(marker: MarkerIn):
        shot = shot_or_404(marker.shot)
        check_marker_xy(shot, marker.x, marker.y)
        return store.add({**marker.model_dump(), **cad_under(shot, marker.x, marker.y)})

    @app.patch("/api/markers/{marker_id}")
    def edit_marker(marker_id: int, patch: MarkerPatch):
        current = marker_or_404(marker_id)
        values = patch.model_dump(exclude_unset=True)
        if "x" in values or "y" in values:
            shot = source.shots.get(current["shot"])
            if shot is None:  # left in the database by an earlier review of this folder
                raise HTTPException(409, f"marker {marker_id} is on shot {current['shot']!r}, which this review "
                                         "no longer has: it can be edited or deleted, not moved")
            x, y = values.get("x", current["x"]), values.get("y", current["y"])
            check_marker_xy(shot, x, y)
            values.update(cad_under(shot, x, y))
        return store.update(marker_id, values)

    @app.delete("/api/markers/{marker_id}")
    def delete_marker(marker_id: int):
        if not (1 <= marker_id <= MAX_ID and store.delete(marker_id)):
            raise HTTPException(404, f"no marker {marker_id}")
        return {"deleted": marker_id}

    @app.get("/api/export/report.html")
    def export_html():
        return HTMLResponse(report_html(source, renders, store.markers()),
                            headers={"Content-Disposition": 'attachment; filename="review.html"'})

    @app.get("/api/export/markers.csv")
    def export_csv():
        # UTF-8 with a byte-order mark: Excel, the planners' usual tool, otherwise reads notes
        # with umlauts as Latin-1
        return Response(("\ufeff" + markers_csv(store.markers())).encode("utf-8"), media_type="text/csv; charset=utf-8",
                        headers={"Content-Disposition": 'attachment; filename="review.csv"'})

    return app


def _url_host(host: str) -> str:
    """The host part of the printed URL: for an address bound on every interface (0.0.0.0, ::),
    the machine's name, which a colleague's browser can open."""
    if host in ALL_INTERFACES:
        return socket.gethostname()
    return f"[{host}]" if ":" in host else host


def listen(host: str, port: int) -> socket.socket:
    """The server's socket, bound and listening (as uvicorn binds it), before the URL is printed
    and anything is written: a busy or impossible port is a one-line error, and no other program
    can take the port between this check and the server's start."""
    sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # a restart need not wait out TIME_WAIT
    try:
        sock.bind((host, port))
        sock.listen()
    except (OSError, OverflowError) as exc:  # OverflowError: a port outside 0..65535
        sock.close()
        if getattr(exc, "errno", None) == errno.EADDRINUSE:
            raise MrcheckError(f"port {port} is in use; pick another with --port") from None
        raise MrcheckError(f"cannot listen on {host} port {port} ({getattr(exc, 'strerror', None) or exc})") from None
    return sock


def serve(target, shots_dir=None, host="127.0.0.1", port=8765, token=None, db=None, suggestions=(), max_body=MAX_BODY):
    """``mrcheck review``: open the source, print the URL, run uvicorn until interrupted."""
    import secrets

    import uvicorn

    from mrcheck.apps.review.source import open_source
    from mrcheck.apps.review.suggestions import load_suggestions, suggestions_file

    if token is not None and not token.strip():
        raise MrcheckError("--token must not be empty (omit it on loopback; elsewhere one is generated)")
    if db is not None and not str(db).strip():
        raise MrcheckError("--db must not be empty (omit it for review.sqlite beside the export, job or shots)")
    if max_body < MIN_MAX_BODY:
        raise MrcheckError(f"--max-body must be at least {format_size(MIN_MAX_BODY)}: a marker with a long note "
                           "takes up to 26 kB")
    source = open_source(target, shots_dir)
    suggested = load_suggestions(source, suggestions)
    database = database_path(source, db)
    # SQLite writes the database and its -wal, -shm and -journal files; the cache prunes its own folder
    check_not_inputs([Path(f"{database}{suffix}") for suffix in ("", "-wal", "-shm", "-journal")],
                     [*source.inputs(), ("--suggestions", [suggestions_file(s) for s in suggestions])],
                     folders=[database.parent / CACHE])
    if token is None and not is_loopback(host):
        token = secrets.token_urlsafe(18)
    sock = listen(host, port)  # before create_app writes the database
    try:
        app = create_app(source, db_path=database, token=token, suggestions=suggested, host=host,
                         max_body=max_body)
        url = f"http://{_url_host(host)}:{port}/" + (f"?token={token}" if token else "")
        print(f"mrcheck review: {len(source.shots)} shot(s) of {source.label}", flush=True)
        store = app.state.store
        if store.created and store.others:  # a shared --db, or a folder moved away from its database
            where = lambda name: os.path.normpath(store.path.resolve().parent / name)  # noqa: E731 (names are relative)
            print(f"review database {store.path}: a new review of {Path(source.origin).resolve()}; its other "
                  f"review(s), kept apart: {', '.join(map(where, store.others))}", flush=True)
        if suggested:
            added = app.state.imported
            print(f"suggestions: {sum(added.values())} new marker(s) on {len(added)} shot(s) (category 'suggested'; "
                  "each part or region is imported once per review)", flush=True)
        print(f"open {url}", flush=True)
        try:
            uvicorn.Server(uvicorn.Config(app, log_level="warning")).run(sockets=[sock])
        except KeyboardInterrupt:  # uvicorn re-raises the Ctrl-C it shut down on: the normal way to stop
            pass
    finally:
        sock.close()
