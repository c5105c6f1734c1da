"""The render session (:mod:`..viewsession`): the WebSocket a page moves its camera through, and
the CAD point under a pixel of any camera (orbit pivot, measuring, the part's name); the live
session (:mod:`..livesession`): a camera's video frames tracked."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends, HTTPException, WebSocket
from pydantic import BaseModel, Field

from mrcheck.apps.review.crosssite import JSON, requires
from mrcheck.apps.review.livesession import frozen_image, live_session
from mrcheck.apps.review.middleware import token_allows
from mrcheck.apps.review.routes.shots import shot_entry
from mrcheck.apps.review.state import Review, check_pixel, current
from mrcheck.apps.review.viewsession import parse_request, view_session

router = APIRouter(prefix="/api")
Current = Annotated[Review, Depends(current)]
REFUSED = 1008  # WebSocket close code "policy violation": the token is missing or wrong


@router.websocket("/view")
async def view(websocket: WebSocket):
    """The render session (:mod:`..viewsession`)."""
    review = await _accepted(websocket)
    if review is not None:
        await view_session(review.view_renderer(), review.source.shots).serve(websocket)


@router.websocket("/live")
async def live(websocket: WebSocket):
    """The live check's frames, tracked (:mod:`..livesession`)."""
    review = await _accepted(websocket)
    if review is not None:
        await live_session(review.source, review.renders, review.marker_map, review.live_camera).serve(websocket)


async def _accepted(websocket: WebSocket) -> Review | None:
    """The review, once the handshake is accepted; None when the token is missing or wrong
    (closed with :data:`REFUSED`). The Host and other-site checks came first (.guard)."""
    if not token_allows(websocket.app, websocket.query_params.get("token"), websocket.cookies):
        await websocket.close(code=REFUSED, reason="a valid token is required (?token=...)")
        return None
    await websocket.accept()
    return websocket.app.state.review


class Frozen(BaseModel):
    shot: str  # the shot the live track started from: its intrinsics and lens
    R: list[list[float]] = Field(min_length=3, max_length=3)
    t: list[float] = Field(min_length=3, max_length=3)
    image: str = Field(max_length=4 << 20)  # base64 JPEG or PNG of the frame, at the served size


@router.post("/live/freeze", status_code=201, dependencies=[Depends(requires(JSON))])
def freeze(review: Current, body: Frozen):
    """A frame of the live check, frozen: saved with its tracked pose as a new shot (freeze and
    mark: the planner places markers on it as on any shot)."""
    try:
        request = parse_request({"shot": body.shot, "R": body.R, "t": body.t}, review.source.shots)
        live = review.live_camera.for_shot(review.source.shots[body.shot])  # Live's intrinsics (.livecamera)
        image = frozen_image(body.image, live)
    except ValueError as exc:
        raise HTTPException(422, str(exc)) from None
    camera = live.with_pose(request.R, request.t)
    return shot_entry(review.addphoto.save_frame(f"live-{body.shot}", image, camera, {"method": "live"}))


class Staged(BaseModel):
    shot: str  # the shot whose intrinsics the live track uses
    image: str = Field(max_length=4 << 20)  # base64 JPEG or PNG of the frame, at Live's camera's size


@router.post("/live/clicks", status_code=201, dependencies=[Depends(requires(JSON))])
def clicks(review: Current, body: Staged):
    """A frozen frame of the live check staged for "Add photo" with the live intrinsics: the
    planner clicks 4+ points on it and the CAD, saves the shot, and Live starts from it."""
    live = review.live_camera.for_shot(review.shot_or_404(body.shot))  # Live's intrinsics (.livecamera)
    try:
        image = frozen_image(body.image, live)
    except ValueError as exc:
        raise HTTPException(422, str(exc)) from None
    return review.addphoto.stage_frame(image, live)


class ViewPick(BaseModel):
    shot: str
    R: list[list[float]] = Field(min_length=3, max_length=3)
    t: list[float] = Field(min_length=3, max_length=3)
    x: float
    y: float


@router.post("/view/pick", dependencies=[Depends(requires(JSON))])
def view_pick(review: Current, body: ViewPick):
    """The CAD part and world point under pixel (x, y) of the shot's camera moved to (R, t)."""
    review.shot_or_404(body.shot)
    try:
        request = parse_request({"shot": body.shot, "R": body.R, "t": body.t}, review.source.shots)
    except ValueError as exc:
        raise HTTPException(422, str(exc)) from None
    camera = review.view_renderer().camera(request)  # at the served size, the page's pixels
    check_pixel(camera.width, camera.height, body.x, body.y)
    return review.picker().pick(camera, body.x, body.y, point=True)
