"""The written results of a deviation: ``parts.json`` / ``parts.md`` (the ranked per-instance
list) and ``deviations.npy`` (float32 (N,) signed distance of every scan point, metres, scan
order)."""

from __future__ import annotations

import io
import json
from dataclasses import asdict, dataclass

import numpy as np

from mrcheck.apps.deviation.distances import Deviation, PartDeviation

DEVIATIONS, PARTS_JSON, PARTS_MD = "deviations.npy", "parts.json", "parts.md"  # written into OUTDIR
SIGN = "sign of (point - closest point) . closest triangle normal; > 0 in front of the CAD surface"


@dataclass
class DeviationReport:
    """``parts.json``: the whole scan's figures (metres) and the ranked instances."""

    scan: str
    scene: str
    units: str  # of the scan file
    points: int
    median_abs: float
    mean_abs: float
    p95_abs: float
    signed_mean: float
    distance_unit: str
    sign: str
    colour_scale_mm: float  # S of the images' colour map
    parts: list[PartDeviation]
    crs: str | None = None  # the coordinate reference system the scan file names (LAS/LAZ)

    def to_dict(self) -> dict:
        return asdict(self)


def make_report(result: Deviation, scan, scene, units, scale_mm: float, crs: str | None = None) -> DeviationReport:
    d = result.distances
    a = np.abs(d)
    return DeviationReport(
        scan=str(scan),
        scene=str(scene),
        units=units or "m",
        points=int(len(d)),
        median_abs=float(np.median(a)),
        mean_abs=float(a.mean()),
        p95_abs=float(np.percentile(a, 95)),
        signed_mean=float(d.mean()),
        distance_unit="m",
        sign=SIGN,
        colour_scale_mm=scale_mm,
        parts=result.parts,
        crs=crs,
    )


def parts_json(report: DeviationReport) -> str:
    return json.dumps(report.to_dict(), indent=2) + "\n"


def _mm(value) -> str:
    return "-" if value is None else f"{value * 1000.0:.2f}"


def parts_markdown(report: DeviationReport) -> str:
    """The text of ``parts.md``: the whole scan's figures, then the ranked instances in mm."""
    lines = [
        f"# Deviation of {report.scan} from {report.scene}",
        "",
        f"{report.points} scan points; median |d| {_mm(report.median_abs)} mm, "
        f"95th percentile {_mm(report.p95_abs)} mm. Signed: > 0 in front of the CAD surface "
        "(along the closest triangle's normal), < 0 behind it.",
        "",
        "| rank | instance | part | points | median abs (mm) | mean abs (mm) | p95 abs (mm) | signed mean (mm) |",
        "|---:|---|---|---:|---:|---:|---:|---:|",
    ]
    for r in report.parts:
        lines.append(
            f"| {r.rank} | {r.id} | {r.part} | {r.points} | {_mm(r.median_abs)} | "
            f"{_mm(r.mean_abs)} | {_mm(r.p95_abs)} | {_mm(r.signed_mean)} |"
        )
    return "\n".join(lines) + "\n"


def npy_bytes(array: np.ndarray) -> bytes:
    """``array`` as the bytes of a .npy file."""
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


__all__ = [
    "DeviationReport",
    "make_report",
    "parts_json",
    "parts_markdown",
    "npy_bytes",
    "DEVIATIONS",
    "PARTS_JSON",
    "PARTS_MD",
]
