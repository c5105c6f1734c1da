"""The review web app: FastAPI routes (:mod:`.routes`) over a Source, a Store, a RenderService
and a Picker, shared as ``app.state.review`` (:class:`.state.Review`).

Files are served by shot name + kind only (never by a client-given path); static files from a
fixed table. Before anything else, a request must name this server in its Host header (else 403),
must not change state from another site's page (else 403, :mod:`.crosssite`) and its body must be
within the limit (else 413), see :mod:`.guard`. With a token, every request
needs it (query ``token``, header ``X-Review-Token`` or the cookie set when the page is opened
with ``?token=``), else 401 (:mod:`.middleware`).
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from fastapi import FastAPI

from mrcheck.apps.bcf import default_author
from mrcheck.apps.names import REVIEW_CACHE, REVIEW_DATABASE, REVIEW_TLS
from mrcheck.apps.review import middleware
from mrcheck.apps.review.addphoto import AddPhoto
from mrcheck.apps.review.calibrator import Calibrator
from mrcheck.apps.review.guard import MAX_BODY, MAX_UPLOAD
from mrcheck.apps.review.livecamera import LiveCamera, LiveIntrinsics
from mrcheck.apps.review.renders import RenderService
from mrcheck.apps.review.routes import ROUTERS
from mrcheck.apps.review.state import Review
from mrcheck.apps.review.storage import Store
from mrcheck.apps.review.viewsession import DEFAULT_ACCUMULATE


def database_path(source, db_path=None) -> Path:
    """The review database: ``--db``, else review.sqlite in the source's home."""
    return Path(db_path or source.home / REVIEW_DATABASE)


def cache_path(db_path: Path) -> Path:
    """The render cache: beside the database."""
    return Path(db_path).parent / REVIEW_CACHE


def tls_path(db_path: Path) -> Path:
    """The certificates of ``--self-signed``: beside the database, like the cache."""
    return Path(db_path).parent / REVIEW_TLS


def create_app(
    source,
    db_path: Path | None = None,
    cache_dir: Path | None = None,
    token: str | None = None,
    samples: int = 16,
    suggestions: dict | None = None,
    host: str | None = None,
    max_body: int = MAX_BODY,
    max_upload: int = MAX_UPLOAD,
    antialias: bool = True,
    author: str | None = None,
    accumulate: int = DEFAULT_ACCUMULATE,
    marker_map=None,
    live_intrinsics: LiveIntrinsics | None = None,
    board: str | None = None,
) -> FastAPI:
    """``suggestions``: {shot name: markers} (:func:`.suggestions.load_suggestions`), imported
    into the review's markers once; ``app.state.imported``: {shot name: markers added now}.
    ``host``: the address the server is bound to, whose names alone a request's Host header may
    give (:func:`.guard.host_names`); None checks no Host (an app not on a socket, as in tests).
    ``max_body``: the largest request body, in bytes; ``max_upload``: the largest upload of "Add photo".
    ``antialias``: the CAD renders anti-aliased (mrcheck.render.antialias); ``author``: who
    writes the BCF topics and the comments made in the review (None: the OS user); ``accumulate``:
    the AO frames of a render session's frame at rest (:mod:`.viewsession`); ``marker_map``: the
    markers Live may start from (:class:`mrcheck.mr.markers.MarkerMap`, ``--marker-map``);
    ``live_intrinsics``: Live's camera (``--live-intrinsics``, :mod:`.livecamera`), else the one
    "Calibrate" saved beside the database, else each shot's; ``board``: the board SPEC
    "Calibrate" offers (``--board``)."""
    db_path = database_path(source, db_path)
    store = Store(
        db_path,
        source.review_name(db_path),
        served_scales={s.name: s.served_scale() for s in source.shots.values() if s.served_size != s.size},
    )
    renders = RenderService(source, cache_dir or cache_path(db_path), samples=samples, antialias=antialias)
    review = Review(
        source, store, renders, author=author or default_author(), accumulate=accumulate, marker_map=marker_map
    )
    review.addphoto = AddPhoto(review, renders.cache)
    review.live_camera, review.calibrator = LiveCamera(db_path, live_intrinsics), Calibrator(board)
    review.import_suggestions(suggestions or {})

    @contextlib.asynccontextmanager
    async def lifespan(app):
        yield
        renders.close()

    app = FastAPI(title="mrcheck review", docs_url=None, redoc_url=None, openapi_url=None, lifespan=lifespan)
    app.state.review = review
    app.state.source, app.state.store, app.state.renders = source, store, renders
    app.state.imported = review.imported  # shot -> suggestions added at this start
    middleware.install(app, token, host, max_body, max_upload)
    for router in ROUTERS:
        app.include_router(router)
    return app


__all__ = ["create_app", "database_path", "cache_path", "tls_path"]
