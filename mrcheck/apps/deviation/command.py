"""``mrcheck deviation``: check everything, measure, then write every output atomically.

Outputs in OUTDIR, all written only after every check has passed, all or none::

    deviations.npy       float32 (N,) signed distance of every scan point, metres, scan order
    parts.json, parts.md the ranked per-instance list
    deviation_top.png    top-down orthographic splat of the scan coloured by d, with a legend
    deviation_side.png   the same seen from the front (-y), z up
    deviation_render.png with --shot: the scan projected through the shot's camera (with its
    deviation_overlay.png lens distortion) over the CAD render / the photo-and-CAD overlay

With ``--per-element`` (:mod:`~mrcheck.apps.deviation.elements`) also::

    elements.csv, elements.json  every instance's status (installed, out of tolerance, not found,
                                 not enough data, occluded),
                         points, coverage, median and p95 distance, offset (instance ids,
                         IFC GlobalIds where the scene came from IFC)
    elements.png         the CAD in vector AO tinted by status, over the shot's photo with --shot
    elements.bcfzip      BCF 2.1: one topic per element out of tolerance

``--units`` scales the scan to metres; the scene is loaded as its manifest says.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrcheck.apps.bcf import element_label
from mrcheck.apps.deviation.distances import deviation
from mrcheck.apps.deviation.element_image import element_picture, overview_camera
from mrcheck.apps.deviation.element_report import (
    ELEMENTS_BCF,
    ELEMENTS_CSV,
    ELEMENTS_JSON,
    ELEMENTS_PNG,
    ElementReport,
    elements_bcf,
    elements_csv,
    elements_json,
    make_element_report,
)
from mrcheck.apps.deviation.elements import SEARCH_MM, STATUSES, TOLERANCE_MM, element_status
from mrcheck.apps.deviation.images import (
    SHOT_IMAGES,
    VIEW_IMAGES,
    colour_scale_mm,
    diverging_colours,
    shot_images,
    view_images,
)
from mrcheck.apps.deviation.report import (
    DEVIATIONS,
    PARTS_JSON,
    PARTS_MD,
    DeviationReport,
    make_report,
    npy_bytes,
    parts_json,
    parts_markdown,
)
from mrcheck.core.images import encode_image
from mrcheck.core.output import (
    check_not_inputs,
    check_output_dir,
    check_own_output_dir,
    mark_output_dir,
    write_all_or_none,
    writer,
)
from mrcheck.scene.manifest import scene_files
from mrcheck.scene.scans import read_scan


@dataclass(frozen=True)
class DeviationRun:
    """What ``mrcheck deviation`` measured and where it wrote it."""

    outdir: Path
    report: DeviationReport
    elements: ElementReport | None = None  # with --per-element
    top_label: str = ""  # the top instance as a person reads it (its name, class, storey), "" for its id

    @property
    def summary(self) -> str:
        """The console line: points, median and 95th percentile of |d|, the top instance."""
        r = self.report
        line = (
            f"deviation: {r.points} points, median |d| {r.median_abs * 1000:.3f} mm, "
            f"p95 {r.p95_abs * 1000:.3f} mm; top: {self.top_label or r.parts[0].id}"
        )
        if self.elements is not None:
            c = self.elements.counts
            line += f"; per element at {self.elements.tolerance_mm:g} mm: " + ", ".join(
                f"{c[status]} {status}" for status in STATUSES
            )
        return line


@dataclass(frozen=True)
class PerElement:
    """The ``--per-element`` settings (millimetres)."""

    tolerance_mm: float = TOLERANCE_MM
    search_mm: float = SEARCH_MM
    author: str = "mrcheck"  # of the BCF topics (--author)


def _output_names(shot, per_element) -> list[str]:
    return [
        DEVIATIONS,
        PARTS_JSON,
        PARTS_MD,
        *VIEW_IMAGES.values(),
        *(SHOT_IMAGES if shot is not None else ()),
        *((ELEMENTS_CSV, ELEMENTS_JSON, ELEMENTS_PNG, ELEMENTS_BCF) if per_element is not None else ()),
    ]


def scanner_positions(cloud, scan) -> np.ndarray | None:
    """The scanner positions of an E57 file (its scans' pose translations, metres), else None."""
    if Path(scan).suffix.lower() != ".e57" or not cloud.scans:
        return None
    return np.array([pose.pose[:3, 3] for pose in cloud.scans], np.float64)


def element_outputs(
    result, loaded, cloud, scan, scene, settings: PerElement, outdir: Path, camera=None, photo=None
) -> tuple[ElementReport, dict]:
    """The per-element table and ``{file name: bytes or text or image}`` of its outputs."""
    scanners = scanner_positions(cloud, scan)
    rows = element_status(result.surface, loaded, cloud.points, settings.tolerance_mm, settings.search_mm, scanners)
    shot_camera = camera if camera is not None else overview_camera(loaded)
    drawn = element_picture(loaded, rows, settings.tolerance_mm, shot_camera, photo)
    picture = drawn.image
    report = make_element_report(rows, scan, scene, settings.tolerance_mm, settings.search_mm, scanners)
    bcf = elements_bcf(
        rows,
        loaded,
        settings.tolerance_mm,
        str(outdir.resolve()),
        shot_camera,
        encode_image(ELEMENTS_PNG, picture),
        settings.author,
        drawn.boxes,
    )
    return report, {
        ELEMENTS_CSV: elements_csv(rows),
        ELEMENTS_JSON: elements_json(report),
        ELEMENTS_PNG: picture,
        ELEMENTS_BCF: bcf,
    }


def deviation_command(
    scan, scene, shot=None, units=None, outdir="deviation", per_element: PerElement | None = None
) -> DeviationRun:
    """Check the inputs (the shot's and the scan's errors before the slow scene load), measure
    the scan against the scene, then write every output of OUTDIR (module docstring)."""
    from mrcheck.core.camerafiles import load_shot, read_photo
    from mrcheck.scene.model import load_scene

    outdir = check_output_dir(outdir)
    camera = photo = photo_path = None
    if shot is not None:
        camera, photo_path = load_shot(shot)
    check_not_inputs(
        [outdir / name for name in _output_names(shot, per_element)],
        [("the scan", scan), ("--shot", shot), ("the shot's photo", photo_path), ("the scene", scene_files(scene))],
    )
    check_own_output_dir(outdir)  # after the inputs: "would overwrite the input" says more
    if shot is not None:
        photo = read_photo(photo_path, camera)
    cloud = read_scan(scan, units)  # the scan's own errors before the slow scene load
    points = cloud.points
    loaded = load_scene(scene, progress=True)
    result = deviation(points, loaded, scan, normals=per_element is not None)

    scale_mm = colour_scale_mm(result.distances)
    colours = diverging_colours(result.distances, scale_mm / 1000.0)
    images = view_images(points, colours, scale_mm)
    if camera is not None:
        images.update(shot_images(loaded, camera, photo, points, colours, scale_mm))
    report = make_report(result, scan, scene, cloud.units, scale_mm, cloud.crs)
    outputs = {
        DEVIATIONS: npy_bytes(result.distances.astype(np.float32)),
        PARTS_JSON: parts_json(report),
        PARTS_MD: parts_markdown(report),
        **images,
    }
    elements = None
    if per_element is not None:
        elements, more = element_outputs(result, loaded, cloud, scan, scene, per_element, outdir, camera, photo)
        outputs.update(more)
    # all or none: a deviations.npy without its parts.json would pass for a complete result
    mark_output_dir(outdir)
    write_all_or_none([writer(outdir / name, content) for name, content in outputs.items()])
    return DeviationRun(outdir, report, elements, element_label(loaded, report.parts[0].id))


__all__ = ["deviation_command", "DeviationRun", "PerElement", "element_outputs", "scanner_positions"]
