"""BCF 2.1: the markers as ``review.bcfzip`` and a BCF file back (statuses, comments, priorities)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends, HTTPException, Request
from fastapi.responses import Response

from mrcheck.apps.review.bcf import export_bcf, import_bcf
from mrcheck.apps.review.state import Review, current
from mrcheck.core.errors import MrcheckError

router = APIRouter(prefix="/api/bcf")
Current = Annotated[Review, Depends(current)]
REVIEW_BCF = "review.bcfzip"


@router.get("/markers.bcfzip")
def export_markers(review: Current):
    return Response(
        export_bcf(review),
        media_type="application/octet-stream",
        headers={"Content-Disposition": f'attachment; filename="{REVIEW_BCF}"'},
    )


@router.post("/import")
async def import_markers(review: Current, request: Request):
    try:
        return import_bcf(review, await request.body()).to_dict()
    except MrcheckError as exc:
        raise HTTPException(400, str(exc)) from None
