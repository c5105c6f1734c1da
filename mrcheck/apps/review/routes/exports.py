"""The review's downloads: the HTML report (review.html) and the markers as CSV (review.csv)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends
from fastapi.responses import HTMLResponse, Response

from mrcheck.apps.names import REVIEW_CSV, REVIEW_REPORT
from mrcheck.apps.review.report import markers_csv, report_html
from mrcheck.apps.review.state import Review, current

router = APIRouter(prefix="/api/export")
Current = Annotated[Review, Depends(current)]


@router.get("/report.html")
def export_html(review: Current):
    return HTMLResponse(
        report_html(review.source, review.renders, review.store.markers()),
        headers={"Content-Disposition": f'attachment; filename="{REVIEW_REPORT}"'},
    )


@router.get("/markers.csv")
def export_csv(review: Current):
    # UTF-8 with a byte-order mark: Excel, the planners' usual tool, otherwise reads notes
    # with umlauts as Latin-1
    return Response(
        ("\ufeff" + markers_csv(review.store.markers())).encode("utf-8"),
        media_type="text/csv; charset=utf-8",
        headers={"Content-Disposition": f'attachment; filename="{REVIEW_CSV}"'},
    )
