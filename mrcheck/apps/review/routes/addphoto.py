""" "Add photo": register a photo by clicking pairs of points on it and on a CAD view, save it as
a shot (:mod:`mrcheck.apps.review.addphoto`). Every problem the planner can cause (fewer than 4
pairs, a CAD click on nothing, collinear clicks, a file that is no image, intrinsics of another
aspect ratio) is a 422 with one line; nothing is saved before ``save``."""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, Body, Depends, HTTPException, Query
from fastapi.responses import Response
from pydantic import BaseModel, ConfigDict, Field

from mrcheck.apps.review.crosssite import JSON, OCTETS, requires
from mrcheck.apps.review.guard import UPLOAD_PATH
from mrcheck.apps.review.state import Review, current
from mrcheck.core.errors import MrcheckError

router = APIRouter(prefix="/api/addphoto")
Current = Annotated[Review, Depends(current)]
_PNG = {"Cache-Control": "no-store"}
Pixel = Annotated[list[float], Field(min_length=2, max_length=2)]


class Pair(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    photo: Pixel
    cad: Pixel


class SolveIn(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    photo: str = Field(max_length=200)
    intrinsics: str = Field(max_length=200)
    view: str = Field(max_length=300)
    pairs: list[Pair] = Field(max_length=200)
    snap: bool = True


def _planner_error(call, *args, **kwargs):
    """``call(*args)``, a MrcheckError (the planner's input) as a one-line 422."""
    try:
        return call(*args, **kwargs)
    except MrcheckError as exc:
        raise HTTPException(422, str(exc)) from None


@router.get("/files")
def files(review: Current):
    return review.addphoto.files()


@router.post(UPLOAD_PATH.removeprefix("/api/addphoto"), status_code=201, dependencies=[Depends(requires(OCTETS))])
def upload(
    review: Current,
    kind: Literal["photo", "intrinsics"],
    data: Annotated[bytes, Body(media_type=OCTETS)],
    filename: str = Query(..., min_length=1, max_length=255),
):
    # the body read by FastAPI, as a marker's is: a chunked body past the limit is its 413
    return _planner_error(review.addphoto.upload, kind, filename, data)


@router.get("/photo")
def photo_info(review: Current, photo: str, intrinsics: str):
    """The photo's size and the intrinsics' check (a size that cannot be the photo's is a 422)."""
    from mrcheck.mr.registration import fit_camera

    def check():
        path, image, camera = review.addphoto.photo_and_camera(photo, intrinsics)
        _, warnings = fit_camera(camera, image.shape[1], image.shape[0], path.name)
        return {"width": image.shape[1], "height": image.shape[0], "warnings": warnings}

    return _planner_error(check)


@router.get("/photo.png")
def photo_png(review: Current, photo: str):
    png, _ = _planner_error(review.addphoto.photo_png, photo)
    return Response(png, media_type="image/png", headers=_PNG)


@router.get("/views")
def views(review: Current):
    from mrcheck.apps.review.addphoto import cad_views

    return [
        {"name": v.name, "label": v.label, "width": v.camera.width, "height": v.camera.height}
        for v in cad_views(review.source).values()
    ]


@router.get("/views/{name}/render.png")
def view_png(review: Current, name: str):
    return Response(_planner_error(review.addphoto.view_png, name), media_type="image/png", headers=_PNG)


@router.get("/views/{name}/pick")
def view_pick(review: Current, name: str, x: float = Query(...), y: float = Query(...)):
    return _planner_error(review.addphoto.pick, name, x, y)


@router.post("/solve", dependencies=[Depends(requires(JSON))])
def solve(review: Current, body: SolveIn):
    ident, solved = _planner_error(
        review.addphoto.solve,
        body.photo,
        body.intrinsics,
        body.view,
        [p.photo for p in body.pairs],
        [p.cad for p in body.pairs],
        body.snap,
    )
    result, shot = solved.solve, solved.solve.shot
    return {
        "id": ident,
        "method": shot.method,
        "snapped": result.snapped,
        "note": result.snap_note,
        "residuals_px": result.residuals_px,
        "click_residuals_px": result.click_residuals_px,
        "rejected": result.rejected,
        "rms_px": round(result.rms_px, 3),
        "edge_rms_px": shot.report["rms"] if result.snapped else None,
        "support": shot.report.get("support"),
        "camera_position": shot.report["camera_position"],
        "warnings": result.warnings,
        "width": result.camera.width,
        "height": result.camera.height,
    }


@router.get("/results/{ident}/overlay.png")
def overlay(review: Current, ident: str):
    solved = _planner_error(review.addphoto.solved, ident)
    return Response(solved.overlay, media_type="image/png", headers=_PNG)


@router.post("/results/{ident}/save", status_code=201)
def save(review: Current, ident: str):
    shot = _planner_error(review.addphoto.save, ident)
    return {
        "name": shot.name,
        "error_px": shot.error_px,
        "width": shot.size[0],
        "height": shot.size[1],
        "photo": shot.photo.name,
        "folder": review.addphoto.files()["folder"],
    }
