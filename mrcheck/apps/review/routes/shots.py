"""The review's shots: the list, their images (by shot name and kind, never a path) and the
CAD part under a pixel."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends, HTTPException, Query
from fastapi.responses import FileResponse

from mrcheck.apps.review.renders import INTENSITIES
from mrcheck.apps.review.state import Review, check_xy, current
from mrcheck.apps.review.storage import CATEGORIES, MAX_NOTE
from mrcheck.render.renderer import MODES, STUDY_LABELS

KINDS = ("photo", "render", "edges", "thumb")

router = APIRouter(prefix="/api")
Current = Annotated[Review, Depends(current)]


@router.get("/info")
def info(review: Current):
    return {
        "label": review.source.label,
        "modes": list(MODES),
        "labels": STUDY_LABELS,
        "intensities": list(INTENSITIES),
        "categories": list(CATEGORIES),
        "max_note": MAX_NOTE,
        # where Live can start besides a shot's pose: the scene's named viewpoints, the marker map
        "viewpoints": sorted(review.source.loaded.viewpoints),
        "markers": review.marker_map is not None,
    }


@router.get("/shots")
def shots(review: Current):
    return [shot_entry(s) for s in review.source.shots.values()]


def shot_entry(shot) -> dict:
    """A shot as the page lists it: name, registration error, the photo's size, the served camera."""
    return {"name": shot.name, "error_px": shot.error_px, "width": shot.size[0], "height": shot.size[1],
            "camera": served_camera(shot)}  # fmt: skip


def served_camera(shot) -> dict:
    """The shot's camera at the served size: what the render session renders and picks with
    (the page moves its R and t; K is for the page's own projections, the lens stays the server's)."""
    camera = shot.served_camera()
    return {"width": camera.width, "height": camera.height, "K": camera.K.tolist(), "R": camera.R.tolist(),
            "t": camera.t.tolist()}  # fmt: skip


@router.get("/shots/{name}/{kind}.png")
def image(review: Current, name: str, kind: str, mode: str = "phong", intensity: float = 1.0):
    review.shot_or_404(name)
    if kind not in KINDS:
        raise HTTPException(404, f"unknown image kind {kind!r} (use {', '.join(KINDS)})")
    if mode not in MODES:
        raise HTTPException(422, f"unknown mode {mode!r} (use {', '.join(MODES)})")
    if intensity not in INTENSITIES:
        raise HTTPException(422, f"intensity must be one of {', '.join(map(str, INTENSITIES))}")
    path = review.renders.file(name, kind, mode, intensity)
    return FileResponse(path, media_type="image/png", headers={"Cache-Control": "private, max-age=3600"})


@router.get("/shots/{name}/pick")
def pick(review: Current, name: str, x: float = Query(...), y: float = Query(...)):
    shot = review.shot_or_404(name)
    check_xy(shot, x, y)
    return review.picker().pick(shot.camera, x, y)
