"""The markers: list, add, edit (moving one picks the CAD part under it again, and measures its
offset again; its BCF status too), measure its offset from a CAD point (:mod:`..measure`),
comment, delete. Every answer carries a marker's BCF status and comments and its part's
name (:func:`.bcf.with_bcf_state`)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends, HTTPException

from mrcheck.apps.review.bcf import with_bcf_state
from mrcheck.apps.review.crosssite import JSON, requires
from mrcheck.apps.review.measure import photo_offset
from mrcheck.apps.review.models import CommentIn, MarkerIn, MarkerPatch, OffsetIn
from mrcheck.apps.review.state import MAX_ID, Review, check_xy, current

router = APIRouter(prefix="/api/markers")
Current = Annotated[Review, Depends(current)]
AS_JSON = [Depends(requires(JSON))]


@router.get("")
def list_markers(review: Current, shot: str | None = None):
    if shot is not None:
        review.shot_or_404(shot)
    return with_bcf_state(review, review.store.markers(shot))


@router.post("", status_code=201, dependencies=AS_JSON)
def add_marker(review: Current, marker: MarkerIn):
    shot = review.shot_or_404(marker.shot)
    check_xy(shot, marker.x, marker.y)
    return _shown(review, review.store.add({**marker.model_dump(), **review.cad_under(shot, marker.x, marker.y)}))


def _shown(review: Review, marker: dict) -> dict:
    return with_bcf_state(review, [marker])[0]


@router.patch("/{marker_id}", dependencies=AS_JSON)
def edit_marker(review: Current, marker_id: int, patch: MarkerPatch):
    current_marker = review.marker_or_404(marker_id)
    values = patch.model_dump(exclude_unset=True)
    if "status" in values:
        review.store.set_status(marker_id, values.pop("status"))
    if "x" in values or "y" in values:
        shot = review.source.shots.get(current_marker["shot"])
        if shot is None:  # left in the database by an earlier review of this folder
            raise HTTPException(
                409,
                f"marker {marker_id} is on shot {current_marker['shot']!r}, which this review "
                "no longer has: it can be edited or deleted, not moved",
            )
        x, y = values.get("x", current_marker["x"]), values.get("y", current_marker["y"])
        check_xy(shot, x, y)
        values.update(review.cad_under(shot, x, y))
        if current_marker["offset"] is not None:  # from the same CAD point, to where the marker is now
            cad = (current_marker["offset"]["cad_x"], current_marker["offset"]["cad_y"])
            review.store.set_offset(marker_id, _measured(review, shot, (x, y), cad))
    return _shown(review, review.store.update(marker_id, values))


@router.put("/{marker_id}/offset", dependencies=AS_JSON)
def measure_offset(review: Current, marker_id: int, cad: OffsetIn):
    """The marker's offset in metres from the CAD point at pixel (x, y) of its shot: where the
    photo shows the thing (the marker) against where it is planned (:mod:`..measure`)."""
    marker = review.marker_or_404(marker_id)
    shot = review.source.shots.get(marker["shot"])
    if shot is None:
        raise HTTPException(409, f"marker {marker_id} is on shot {marker['shot']!r}, which this review no longer has")
    check_xy(shot, cad.x, cad.y)
    return _shown(
        review, review.store.set_offset(marker_id, _measured(review, shot, (marker["x"], marker["y"]), (cad.x, cad.y)))
    )


@router.delete("/{marker_id}/offset")
def clear_offset(review: Current, marker_id: int):
    review.marker_or_404(marker_id)
    return _shown(review, review.store.set_offset(marker_id, None))


def _measured(review: Review, shot, marker_xy, cad_xy) -> dict:
    try:
        return photo_offset(review.picker(), shot.camera, marker_xy, cad_xy).to_dict()
    except ValueError as exc:
        raise HTTPException(422, str(exc)) from None


@router.post("/{marker_id}/comments", status_code=201, dependencies=AS_JSON)
def add_comment(review: Current, marker_id: int, comment: CommentIn):
    review.marker_or_404(marker_id)
    review.store.add_comment(marker_id, review.author, comment.text)
    return _shown(review, review.marker_or_404(marker_id))


@router.delete("/{marker_id}")
def delete_marker(review: Current, marker_id: int):
    if not (1 <= marker_id <= MAX_ID and review.store.delete(marker_id)):
        raise HTTPException(404, f"no marker {marker_id}")
    return {"deleted": marker_id}
