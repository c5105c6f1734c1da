"""BCF 2.1: the markers as ``review.bcfzip`` and a BCF file back (statuses, comments, priorities).
An import is read in a worker thread, so the server answers other requests meanwhile."""

from __future__ import annotations

import tempfile
from typing import Annotated

from fastapi import APIRouter, Depends, HTTPException, Request
from fastapi.responses import Response
from starlette.concurrency import run_in_threadpool

from mrcheck.apps.review.bcf import export_bcf, import_bcf
from mrcheck.apps.review.crosssite import OCTETS, requires
from mrcheck.apps.review.state import Review, current
from mrcheck.core.errors import MrcheckError

router = APIRouter(prefix="/api/bcf")
Current = Annotated[Review, Depends(current)]
REVIEW_BCF = "review.bcfzip"
SPOOL = 1 << 20  # bytes of an uploaded BCF file kept in memory; the rest goes to a temporary file


@router.get("/markers.bcfzip")
def export_markers(review: Current):
    return Response(
        export_bcf(review),
        media_type="application/octet-stream",
        headers={"Content-Disposition": f'attachment; filename="{REVIEW_BCF}"'},
    )


@router.post("/import", dependencies=[Depends(requires(OCTETS))])
async def import_markers(review: Current, request: Request):
    with tempfile.SpooledTemporaryFile(max_size=SPOOL) as body:
        async for chunk in request.stream():  # counted against --max-body as it arrives (guard)
            body.write(chunk)
        body.seek(0)
        try:
            return (await run_in_threadpool(import_bcf, review, body)).to_dict()
        except MrcheckError as exc:
            raise HTTPException(400, str(exc)) from None
