"""The review's routes, one router per concern: :mod:`.pages` (the page and its static files),
:mod:`.shots` (shots, their images, picking the CAD part under a pixel), :mod:`.markers` (the
markers' CRUD), :mod:`.exports` (the HTML report and the CSV), :mod:`.bcf` (BCF 2.1 out and in)
and :mod:`.addphoto` (a photo registered by clicks, saved as a shot), :mod:`.view` (the render
session's WebSocket and its picks), :mod:`.calibrate` ("Calibrate this camera", Live's camera). Each takes the app's
:class:`~mrcheck.apps.review.state.Review` through the ``current`` dependency."""

from mrcheck.apps.review.routes import addphoto, bcf, calibrate, exports, markers, pages, shots, view

ROUTERS = (
    pages.router,
    shots.router,
    markers.router,
    exports.router,
    bcf.router,
    addphoto.router,
    view.router,
    calibrate.router,
)

__all__ = ["ROUTERS"]
