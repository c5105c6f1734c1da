"""What wraps every route of the review app, outermost first: the Host and body-size checks
(:mod:`.guard`), the handler of unexpected errors (a bug: the API's error shape, one line on the
server's console), the token check; and the handlers that give every error the API's shape
``{"error": ...}``."""

from __future__ import annotations

import hmac
import logging
import os
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from mrcheck.apps.review.guard import UPLOAD_PATHS, RequestCheck, host_names, too_large
from mrcheck.core.errors import MrcheckError, bug_reason

COOKIE = "mrcheck_review_token"
log = logging.getLogger("mrcheck.review")


def _error_handlers(app: FastAPI, max_body: int, max_upload: int) -> None:
    @app.exception_handler(RequestValidationError)
    async def _invalid(request, exc):
        errors = [f"{'.'.join(str(p) for p in e['loc'][1:]) or e['loc'][0]}: {e['msg']}" for e in exc.errors()]
        return JSONResponse({"error": "invalid input", "details": errors}, status_code=422)

    @app.exception_handler(StarletteHTTPException)  # the routing's own 404 / 405 too, not only ours
    async def _http(request, exc):
        # the body limit's own "Content Too Large" names neither the limit nor the option
        upload = request.url.path in UPLOAD_PATHS
        detail = (
            too_large(max_upload if upload else max_body, option="--max-upload" if upload else "--max-body")
            if exc.status_code == 413
            else exc.detail
        )
        return JSONResponse({"error": detail}, status_code=exc.status_code, headers=exc.headers)

    @app.exception_handler(MrcheckError)
    async def _input_file(request, exc):
        # a shot's photo changed on disk after start-up (open_source checked them): 404 when it is
        # gone, else a server-side problem (a photo replaced by one of another size), not the client's
        gone = exc.path is not None and not Path(exc.path).exists()
        return JSONResponse({"error": str(exc)}, status_code=404 if gone else 500)


def token_allows(app: FastAPI, given: str | None, cookies) -> bool:
    """Whether a request giving ``given`` (or the cookie in ``cookies``) may use ``app``: always
    without a token; the WebSocket route asks this itself (the middleware sees HTTP only)."""
    token = getattr(app.state, "token", None)
    given = given or cookies.get(COOKIE)
    return token is None or (bool(given) and hmac.compare_digest(given.encode(), token.encode()))


def _token_check(app: FastAPI, token: str) -> None:
    """Every request needs the token: query ``token``, header ``X-Review-Token`` or the cookie
    set when the page is opened with ``?token=``; else 401."""
    app.state.token = token

    @app.middleware("http")
    async def _token(request: Request, call_next):
        given = request.query_params.get("token") or request.headers.get("x-review-token")
        if not token_allows(app, given, request.cookies):
            return JSONResponse({"error": "a valid token is required (?token=...)"}, status_code=401)
        response = await call_next(request)
        if request.query_params.get("token"):
            # Secure over https: the browser never sends it over plain http (to port 80 of this name, say)
            secure = request.url.scheme == "https"
            response.set_cookie(COOKIE, token, httponly=True, samesite="strict", secure=secure)
        return response


def _unexpected_errors(app: FastAPI) -> None:
    @app.middleware("http")  # outside the token check: also what the token check might raise
    async def _unexpected(request: Request, call_next):
        try:
            return await call_next(request)
        except Exception as exc:  # a bug, not bad input: the API's error shape, one line on the console
            debug = bool(os.environ.get("MRCHECK_DEBUG"))
            reason = bug_reason(exc)
            log.error(
                f"internal error in {request.method} {request.url.path}, please report it: {reason}"
                + ("" if debug else " (MRCHECK_DEBUG=1 shows the traceback)"),
                exc_info=debug,
            )
            return JSONResponse({"error": f"internal error, please report it: {reason}"}, status_code=500)


def install(app: FastAPI, token: str | None, host: str | None, max_body: int, max_upload: int) -> None:
    """The handlers and middleware of the review app (see the module's docstring). ``host``: the
    bound address whose names alone a request's Host may give; None checks no Host."""
    _error_handlers(app, max_body, max_upload)
    if token is not None:
        _token_check(app, token)
    _unexpected_errors(app)
    # added last, so outermost: before the token check
    app.add_middleware(
        RequestCheck, hosts=None if host is None else host_names(host), max_body=max_body, max_upload=max_upload
    )
