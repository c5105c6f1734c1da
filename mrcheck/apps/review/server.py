"""``mrcheck review``: open what is reviewed, bind the port, make the app (:func:`start`), then
serve it until interrupted (:meth:`ReviewServer.run`). What the server says at start-up is
returned (:meth:`ReviewServer.messages`) for the command line to print."""

from __future__ import annotations

import errno
import os
import secrets
import socket
from dataclasses import dataclass
from pathlib import Path

from mrcheck.apps.names import TLS_CA, TLS_CERT, TLS_KEY
from mrcheck.apps.review.app import cache_path, create_app, database_path, tls_path
from mrcheck.apps.review.guard import (
    ALL_INTERFACES,
    MAX_BODY,
    MAX_UPLOAD,
    MIN_MAX_BODY,
    format_size,
    is_loopback,
)
from mrcheck.apps.review.livecamera import calibrated_path, read_intrinsics
from mrcheck.apps.review.selfsigned import self_signed_tls, server_names
from mrcheck.apps.review.tls import Tls, TlsOptions, given_tls
from mrcheck.apps.review.viewsession import DEFAULT_ACCUMULATE
from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import parse_pixels
from mrcheck.core.output import check_not_inputs
from mrcheck.mr.markers import load_marker_map
from mrcheck.render.settings import MAX_ACCUMULATE


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


@dataclass
class ReviewServer:
    app: object  # the FastAPI app
    sock: socket.socket  # bound and listening
    url: str  # what the planner opens (with the token, if any)
    suggested: bool  # --suggestions were given
    tls: Tls | None = None  # HTTPS with this certificate (None: plain http)

    def messages(self) -> list:
        """What the server says when it starts: what is reviewed, the database's other reviews,
        the suggestions imported, the URL."""
        source, store = self.app.state.source, self.app.state.store
        lines = [f"mrcheck review: {len(source.shots)} shot(s) of {source.label}"]
        if store.created and store.others:  # a shared --db, or a folder moved away from its database
            where = lambda name: os.path.normpath(store.path.resolve().parent / name)  # noqa: E731 (names are relative)
            lines.append(
                f"review database {store.path}: a new review of {Path(source.origin).resolve()}; its other "
                f"review(s), kept apart: {', '.join(map(where, store.others))}"
            )
        if self.suggested:
            added = self.app.state.imported
            lines.append(
                f"suggestions: {sum(added.values())} new marker(s) on {len(added)} shot(s) (category "
                "'suggested'; each part or region is imported once per review)"
            )
        lines += self.app.state.review.live_camera.lines()
        lines += self.tls.lines() if self.tls else []
        lines.append(f"open {self.url}")
        return lines

    def config(self):
        """uvicorn's configuration of this server (HTTPS with :attr:`tls`)."""
        import uvicorn

        return uvicorn.Config(self.app, log_level="warning", **(self.tls.uvicorn_options() if self.tls else {}))

    def run(self) -> None:
        """Serve until interrupted (Ctrl-C), then close the socket."""
        import uvicorn

        try:
            uvicorn.Server(self.config()).run(sockets=[self.sock])
        except KeyboardInterrupt:  # uvicorn re-raises the Ctrl-C it shut down on: the normal way to stop
            pass
        finally:
            self.close()

    def close(self) -> None:
        self.sock.close()


def _check_options(token, db, max_body) -> None:
    if token is not None and not token.strip():
        raise MrcheckError("--token must not be empty (omit it on loopback; elsewhere one is generated)")
    if db is not None and not str(db).strip():
        raise MrcheckError("--db must not be empty (omit it for review.sqlite beside the export, job or shots)")
    if max_body < MIN_MAX_BODY:
        raise MrcheckError(
            f"--max-body must be at least {format_size(MIN_MAX_BODY)}: a marker with a long note takes up to 26 kB"
        )


def start(
    target,
    shots_dir=None,
    host="127.0.0.1",
    port=8765,
    token=None,
    db=None,
    suggestions=(),
    max_body=MAX_BODY,
    max_upload=MAX_UPLOAD,
    antialias: bool = True,
    max_pixels: int | None = None,
    author: str | None = None,
    accumulate: int = DEFAULT_ACCUMULATE,
    tls: TlsOptions = TlsOptions(),
    marker_map=None,
    live_intrinsics=None,
    board: str | None = None,
) -> ReviewServer:
    """Everything but serving: the source opened and checked, the port bound, the app made (its
    database written), the certificate of ``--self-signed`` kept or made. A bad input is a
    :class:`MrcheckError` before the port is bound. ``max_pixels``: the largest photo read
    (None: :data:`.source.MAX_PIXELS`); ``author``: of the BCF topics and comments (None: the OS
    user); ``accumulate``: the AO frames of a navigated view at rest; ``tls``: HTTPS;
    ``marker_map``: the marker map file Live may start from (``--marker-map``); ``live_intrinsics``:
    Live's camera file (:mod:`.livecamera`); ``board``: "Calibrate"'s board SPEC."""
    from mrcheck.apps.review.source import open_source
    from mrcheck.apps.review.suggestions import load_suggestions, suggestions_file
    from mrcheck.mr.boards import parse_board

    _check_options(token, db, max_body)
    tls.check()
    served = given_tls(tls)  # --tls-cert and --tls-key, as uvicorn will load them
    if not 1 <= accumulate <= MAX_ACCUMULATE:
        raise MrcheckError(f"--accumulate must be 1 to {MAX_ACCUMULATE} frames, got {accumulate}")
    markers = load_marker_map(marker_map) if marker_map else None  # a bad map: one line, before anything
    if board is not None:
        parse_board(board)  # a bad SPEC now, not when the page starts a calibration
    given = None if live_intrinsics is None else read_intrinsics(live_intrinsics)
    source = open_source(target, shots_dir, **({} if max_pixels is None else {"max_pixels": max_pixels}))
    suggested = load_suggestions(source, suggestions)
    database = database_path(source, db)
    # SQLite writes the database and its -wal, -shm and -journal files; the cache prunes its own folder
    check_not_inputs(
        [Path(f"{database}{suffix}") for suffix in ("", "-wal", "-shm", "-journal")]
        + ([tls_path(database) / name for name in (TLS_CA, TLS_CERT, TLS_KEY)] if tls.self_signed else [])
        + [calibrated_path(database)],  # "Calibrate" writes it: --live-intrinsics must not be it
        [
            *source.inputs(),
            ("--suggestions", [suggestions_file(s) for s in suggestions]),
            ("--live-intrinsics", live_intrinsics),
            ("--marker-map", [marker_map] if marker_map else []),
        ],
        folders=[cache_path(database)],
    )
    if token is None and not is_loopback(host):
        token = secrets.token_urlsafe(18)
    sock = listen(host, port)  # before create_app writes the database
    try:
        app = create_app(
            source,
            db_path=database,
            token=token,
            suggestions=suggested,
            host=host,
            max_body=max_body,
            max_upload=max_upload,
            antialias=antialias,
            author=author,
            accumulate=accumulate,
            marker_map=markers,
            live_intrinsics=given,
            board=board,
        )
    except BaseException:
        sock.close()
        raise
    url = f"{'https' if tls.wanted else 'http'}://{_url_host(host)}:{port}/" + (f"?token={token}" if token else "")
    server = ReviewServer(app, sock, url, bool(suggested), served)
    if tls.self_signed:  # after the database, whose problems (a --db in a missing folder) come first
        try:
            server.tls = self_signed_tls(tls_path(database), server_names(host))
        except BaseException:
            server.close()
            app.state.renders.close()
            raise
    return server


__all__ = ["start", "listen", "parse_pixels", "ReviewServer"]
