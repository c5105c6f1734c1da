"""``mrcheck deviation``: check everything, measure, then write every output atomically.

Outputs in OUTDIR, all written only after every check has passed, all or none::

    deviations.npy       float32 (N,) signed distance of every scan point, metres, scan order
    parts.json, parts.md the ranked per-instance list
    deviation_top.png    top-down orthographic splat of the scan coloured by d, with a legend
    deviation_side.png   the same seen from the front (-y), z up
    deviation_render.png with --shot: the scan projected through the shot's camera (with its
    deviation_overlay.png lens distortion) over the CAD render / the photo-and-CAD overlay

``--units`` scales the scan to metres; the scene is loaded as its manifest says.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrcheck.apps.deviation.distances import deviation
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
from mrcheck.apps.deviation.scans import read_scan
from mrcheck.core.output import (
    check_not_inputs,
    check_output_dir,
    write_all_or_none,
    write_bytes,
    write_image,
    write_text,
)
from mrcheck.scene.manifest import scene_files


@dataclass(frozen=True)
class DeviationRun:
    """What ``mrcheck deviation`` measured and where it wrote it."""
    outdir: Path
    report: DeviationReport

    @property
    def summary(self) -> str:
        """The console line: points, median and 95th percentile of |d|, the top instance."""
        r = self.report
        return (f"deviation: {r.points} points, median |d| {r.median_abs * 1000:.3f} mm, "
                f"p95 {r.p95_abs * 1000:.3f} mm; top: {r.parts[0].id}")


def _output_names(shot) -> list[str]:
    return [DEVIATIONS, PARTS_JSON, PARTS_MD, *VIEW_IMAGES.values(), *(SHOT_IMAGES if shot is not None else ())]


def deviation_command(scan, scene, shot=None, units=None, outdir="deviation") -> DeviationRun:
    """Check the inputs (the shot's and the scan's errors before the slow scene load), measure
    the scan against the scene, then write every output of OUTDIR (module docstring)."""
    from mrcheck.core.camerafiles import load_shot, read_photo
    from mrcheck.scene.model import load_scene

    outdir = check_output_dir(outdir)
    camera = photo = photo_path = None
    if shot is not None:
        camera, photo_path = load_shot(shot)
    check_not_inputs([outdir / name for name in _output_names(shot)],
                     [("the scan", scan), ("--shot", shot), ("the shot's photo", photo_path),
                      ("the scene", scene_files(scene))])
    if shot is not None:
        photo = read_photo(photo_path, camera)
    points = read_scan(scan, units)          # the scan's own errors before the slow scene load
    loaded = load_scene(scene, progress=True)
    result = deviation(points, loaded, scan)

    scale_mm = colour_scale_mm(result.distances)
    colours = diverging_colours(result.distances, scale_mm / 1000.0)
    images = view_images(points, colours, scale_mm)
    if camera is not None:
        images.update(shot_images(loaded, camera, photo, points, colours, scale_mm))
    report = make_report(result, scan, scene, units, scale_mm)
    # all or none: a deviations.npy without its parts.json would pass for a complete result
    write_all_or_none([lambda: write_bytes(outdir / DEVIATIONS, npy_bytes(result.distances.astype(np.float32))),
                       lambda: write_text(outdir / PARTS_JSON, parts_json(report)),
                       lambda: write_text(outdir / PARTS_MD, parts_markdown(report)),
                       *(lambda name=name, image=image: write_image(outdir / name, image) for name, image in images.items())])
    return DeviationRun(outdir, report)


__all__ = ["deviation_command", "DeviationRun"]
