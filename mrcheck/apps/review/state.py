"""What every route of one review app shares (:class:`Review`, ``app.state.review``): the source,
the marker store, the render service and the picker, with the checks the routes have in common."""

from __future__ import annotations

import threading
from dataclasses import dataclass, field

from fastapi import HTTPException, Request

from mrcheck.apps.review.renders import RenderService
from mrcheck.apps.review.source import Source
from mrcheck.apps.review.storage import Store
from mrcheck.apps.review.suggestions import pending
from mrcheck.apps.review.viewsession import DEFAULT_ACCUMULATE, ViewRenderer

MAX_ID = 2**63 - 1  # SQLite's INTEGER range; a larger id cannot be bound (OverflowError), nor exist


@dataclass
class Review:
    source: Source
    store: Store
    renders: RenderService
    imported: dict = field(default_factory=dict)  # shot -> suggestions added at this start
    author: str = "mrcheck"  # who writes the BCF topics and the comments made here (--author)
    addphoto: object = field(default=None, repr=False)  # "Add photo" (:class:`.addphoto.AddPhoto`), set by create_app
    accumulate: int = DEFAULT_ACCUMULATE  # AO frames of a render session's frame at rest (--accumulate)
    marker_map: object = None  # Live's start from markers (--marker-map; :class:`mrcheck.mr.markers.MarkerMap`)
    live_camera: object = field(default=None, repr=False)  # Live's intrinsics (:class:`.livecamera.LiveCamera`)
    calibrator: object = field(default=None, repr=False)  # "Calibrate" (:class:`.calibrator.Calibrator`)
    _picker: object = field(default=None, init=False, repr=False)
    _view: ViewRenderer | None = field(default=None, init=False, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, init=False, repr=False)

    def picker(self):
        """The ray-casting picker, built on first use (it loads the scene into Open3D)."""
        with self._lock:
            if self._picker is None:
                from mrcheck.apps.review.pick import Picker

                self._picker = Picker(self.source.loaded)
            return self._picker

    def view_renderer(self) -> ViewRenderer:
        """The render sessions' renderer (:mod:`.viewsession`), shared by every page."""
        with self._lock:
            if self._view is None:
                self._view = ViewRenderer(self.source, self.renders, self.accumulate)
            return self._view

    def cad_under(self, shot, x, y) -> dict:
        """What a marker at photo pixel (x, y) of ``shot`` stores of the CAD: its part instance and distance."""
        hit = self.picker().pick(shot.camera, x, y)
        return {"part": hit["instance"], "distance": hit["distance"]}

    def import_suggestions(self, suggestions: dict) -> None:
        """{shot name: markers} (:func:`.suggestions.load_suggestions`) into the store, each once
        per review; ``self.imported``: {shot name: markers added now}."""
        for name, markers in suggestions.items():
            # like a marker the planner places: the CAD part under it and its distance; only for the
            # new ones, so that a restart with nothing new does not load the scene for the picker
            shot = self.source.shots[name]
            markers = pending(markers, self.store.imported_keys(name), shot.size[0])
            cads = [self.cad_under(shot, m["x"], m["y"]) for m in markers]
            if added := self.store.import_suggestions(
                name, [{**m, **suggested_cad(m, cad)} for m, cad in zip(markers, cads)]
            ):
                self.imported[name] = added

    def shot_or_404(self, name: str):
        if name not in self.source.shots:
            raise HTTPException(404, f"no shot named {name!r}")
        return self.source.shots[name]

    def marker_or_404(self, marker_id: int) -> dict:
        current = self.store.get(marker_id) if 1 <= marker_id <= MAX_ID else None
        if current is None:
            raise HTTPException(404, f"no marker {marker_id}")
        return current


def suggested_cad(marker: dict, under: dict) -> dict:
    """The part and distance a suggested marker stores. The detector's instance *is* the
    marker's part: what lies under its point may be another one (the point of a moved part's
    unsupported outline can fall on the floor or the wall behind it), so the pick only fills in
    a marker without a part (photo structure no part explains), and its distance is kept only
    when the pick hit the detector's part (else it would be the distance of something else)."""
    part = marker["part"]
    if part is None:
        return {"part": under["part"], "distance": under["distance"]}
    return {"part": part, "distance": under["distance"] if under["part"] == part else None}


def check_xy(shot, x, y) -> None:
    """A marker's or pick's photo pixel lies inside the shot's photo, else 422."""
    check_pixel(*shot.size, x, y)


def check_pixel(w: int, h: int, x, y) -> None:
    """Pixel (x, y) lies inside a ``w`` x ``h`` image, else 422."""
    if not (0 <= x < w and 0 <= y < h):
        raise HTTPException(422, f"coordinates ({x}, {y}) are outside the {w}x{h} image")


def current(request: Request) -> Review:
    """The review of the app serving ``request`` (a FastAPI dependency)."""
    return request.app.state.review
