"""``mrcheck discrepancies``: check the inputs, detect, write ``OUTDIR``'s three files at once.

Outputs (``OUTDIR``, all or none): ``heatmap.png`` (:mod:`mrcheck.apps.discrepancies.heatmap`),
``suspects.json`` and ``suspects.md`` (:mod:`mrcheck.apps.discrepancies.report`), and
``suspects.bcfzip``: BCF 2.1, one topic per suggested marker (:func:`suspects_bcf`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

from mrcheck.apps.bcf import Finding, SharedPicture, bcf_bytes, element_label, finding_topic, topic_guid
from mrcheck.apps.discrepancies.detector import Detection, detect
from mrcheck.apps.discrepancies.heatmap import heatmap
from mrcheck.apps.discrepancies.report import (
    HEATMAP,
    OUTPUT_NAMES,
    SUSPECTS_BCF,
    SUSPECTS_JSON,
    SUSPECTS_MD,
    markdown,
    summary_line,
    suspects_json,
)
from mrcheck.apps.discrepancies.thresholds import MAX_TOLERANCE_SHARE, shift_radius
from mrcheck.core.camerafiles import load_shot, read_photo
from mrcheck.core.errors import MrcheckError, MrcheckWarning
from mrcheck.core.images import encode_image
from mrcheck.core.output import (
    check_not_inputs,
    check_output_dir,
    check_own_output_dir,
    mark_output_dir,
    write_all_or_none,
    write_bytes,
    write_image,
    write_text,
)
from mrcheck.core.shot import read_shot
from mrcheck.scene.manifest import scene_files
from mrcheck.scene.model import load_scene

NOTHING_IN_VIEW = (
    "no CAD part is in view of this shot, so nothing was checked: a wrong pose, or the shot of another scene?"
)


@dataclass(frozen=True)
class DiscrepancyRun:
    """What ``mrcheck discrepancies`` found and wrote."""

    detection: Detection
    paths: list[Path]  # heatmap.png, suspects.json, suspects.md
    labels: dict = field(default_factory=dict)  # {instance id: its name, class and storey} where known

    @property
    def summary(self) -> str:
        """The console line: parts checked, suspects (by name where the scene knows it), regions."""
        return summary_line(self.detection, self.labels)


def _check_tolerance_limit(tolerance_px, camera, shot) -> None:
    # outlines are searched up to SHIFT_RADIUS tolerances away, on arrays padded by as much: a
    # tolerance near the image's size means nothing and costs gigabytes (10000 px: 48 GB)
    limit = MAX_TOLERANCE_SHARE * min(camera.width, camera.height)
    if tolerance_px is not None and tolerance_px > limit:
        raise MrcheckError(
            f"tolerance must be at most {MAX_TOLERANCE_SHARE:.0%} of the photo's shorter side "
            f"({limit:g} px for {camera.width}x{camera.height}), got {tolerance_px:g}",
            shot,
        )


def pose_sigma(shot) -> float:
    """The shot's 1-sigma overlay error (``expected_overlay_error_px``), 0 when it has none."""
    value = read_shot(shot).report.get("expected_overlay_error_px")
    return float(value) if isinstance(value, (int, float)) and math.isfinite(value) and value > 0 else 0.0


def discrepancies_command(shot, scene, tolerance_px=None, outdir=None, author: str = "mrcheck") -> DiscrepancyRun:
    """Validate, detect, then write heatmap.png, suspects.json and suspects.md into ``outdir``.
    A shot that sees no CAD part is warned about (``MrcheckWarning``) and says so in its files."""
    if tolerance_px is not None and not (math.isfinite(tolerance_px) and tolerance_px > 0):
        raise MrcheckError(f"tolerance must be positive, got {tolerance_px}")
    camera, photo_path = load_shot(shot)
    _check_tolerance_limit(tolerance_px, camera, shot)
    outdir = check_output_dir(outdir)
    check_not_inputs(
        [outdir / name for name in OUTPUT_NAMES],
        [("the shot", shot), ("the shot's photo", photo_path), ("the scene", scene_files(scene))],
    )
    check_own_output_dir(outdir)  # after the inputs: "would overwrite the input" says more
    photo = read_photo(photo_path, camera)  # missing, unreadable or wrong-size photo: exit 1
    loaded = load_scene(scene, progress=True)
    sigma = pose_sigma(shot)
    detection = detect(loaded, camera, photo, tolerance_px, pose_sigma_px=sigma)
    if 2.0 * sigma >= shift_radius(detection.tolerance_px):
        detection.warnings.append(
            f"the shot's pose is uncertain by {2.0 * sigma:.1f} px (2 sigma of its expected_overlay_error_px), "
            f"as far as the detector's shifted outlines reach ({shift_radius(detection.tolerance_px)} px): "
            "a part moved less than that is not told from the pose's error; register it better"
        )
    if not detection.suspects:  # "no suspects" would read as "all as planned"
        detection.warnings.append(NOTHING_IN_VIEW)
    for warning in detection.warnings:
        warnings.warn(MrcheckWarning(warning))
    image = heatmap(photo, detection)
    bcf = suspects_bcf(detection, loaded, camera, encode_image(HEATMAP, image), Path(shot).stem, outdir, author)
    mark_output_dir(outdir)
    paths = write_all_or_none(
        [
            lambda: write_image(outdir / HEATMAP, image),
            lambda: write_text(outdir / SUSPECTS_JSON, suspects_json(detection, shot, scene)),
            lambda: write_text(outdir / SUSPECTS_MD, markdown(detection, shot)),
            lambda: write_bytes(outdir / SUSPECTS_BCF, bcf),
        ]
    )
    labels = {s.id: label for s in detection.flagged if (label := element_label(loaded, s.id)) != s.id}
    return DiscrepancyRun(detection, list(paths), labels)


def marker_boxes(detection: Detection) -> list[list[int] | None]:
    """The pixel box of each suggested marker: its suspect's, or its region's (the markers list
    the flagged suspects, then the regions, in order)."""
    suspects = {s.id: s.bbox for s in detection.flagged}
    regions = iter(detection.regions)
    return [suspects.get(m.part) if m.part else next(regions).bbox for m in detection.suggested_markers]


def suspects_bcf(
    detection: Detection, scene, camera, snapshot_png: bytes, shot_name: str, outdir: Path, author: str = "mrcheck"
) -> bytes:
    """``suspects.bcfzip``: a topic per suggested marker (its part's IFC GlobalId where the scene
    has one), with the shot's camera; the heat map once at the zip's root (``heatmap.jpg``,
    downscaled), each topic's snapshot a crop of it around the marker's box
    (:func:`mrcheck.apps.bcf.write.bcf_bytes`); ids stable per output folder."""
    key = str(Path(outdir).resolve())
    heat = SharedPicture("heatmap", snapshot_png, f"heat map of {shot_name}")
    topics = [
        replace(
            finding_topic(
                Finding(topic_guid("discrepancies", key, i), m.category, m.severity, m.note, m.part, shot_name),
                scene,
                camera,
                author=author,
            ),
            shared=heat,
            box=None if box is None else tuple(box),
        )
        for i, (m, box) in enumerate(zip(detection.suggested_markers, marker_boxes(detection)))
    ]
    return bcf_bytes(topics, project=scene.name)


__all__ = ["pose_sigma", "discrepancies_command", "DiscrepancyRun", "suspects_bcf"]
