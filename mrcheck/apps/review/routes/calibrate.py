""" "Calibrate this camera" (:mod:`..calibrator`) and which camera Live uses (:mod:`..livecamera`).
The same checks as every route: the token, the Host and other-site checks, the body limit
(``--max-body``: a video frame as JPEG is some 50-300 kB); JSON or octets only (:mod:`..crosssite`).
Every problem the planner can cause is a 422 with one line."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Body, Depends, HTTPException
from pydantic import BaseModel, ConfigDict, Field

from mrcheck.apps.review.crosssite import JSON, OCTETS, requires
from mrcheck.apps.review.state import Review, current
from mrcheck.core.errors import MrcheckError

router = APIRouter(prefix="/api")
Current = Annotated[Review, Depends(current)]


class Start(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    board: str = Field(min_length=1, max_length=200)


def _planner_error(call, *args):
    try:
        return call(*args)
    except MrcheckError as exc:
        raise HTTPException(422, str(exc)) from None


@router.get("/live/camera")
def live_camera(review: Current):
    """The size Live's frames are sent at and where its intrinsics come from (None: each shot's)."""
    return review.live_camera.describe()


@router.get("/calibrate")
def calibration(review: Current):
    return review.calibrator.state()


@router.post("/calibrate/start", dependencies=[Depends(requires(JSON))])
def start(review: Current, body: Start):
    """A new calibration with this board (the one before is dropped)."""
    return _planner_error(review.calibrator.start, body.board)


@router.post("/calibrate/frame", dependencies=[Depends(requires(OCTETS))])
def frame(review: Current, data: Annotated[bytes, Body(media_type=OCTETS)]):
    """A video frame (JPEG): the board's corners in it, and whether its view was kept."""
    return _planner_error(review.calibrator.frame, data)


@router.post("/calibrate/solve", dependencies=[Depends(requires(JSON))])
def solve(review: Current):
    """The camera of the views kept: saved beside the database and made Live's."""
    return _planner_error(review.calibrator.solve, review.live_camera)
