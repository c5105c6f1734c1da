"""``regress record`` and ``regress check`` as plain functions (the CLI and the pytest plugin
call them): render the views, write the baseline; render again, compare, attribute, report.

Every output is written all or none (:func:`mrcheck.core.output.write_all_or_none`) into a
folder mrcheck made or an empty one; an input (the scene's files, a camera file, the baseline)
is never overwritten.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mrcheck import __version__
from mrcheck.apps.regress.attribution import ChangedElement, attribute, element_label, geometry_changes
from mrcheck.apps.regress.baseline import (
    MANIFEST,
    Baseline,
    BaselineView,
    baseline_writes,
    check_files,
    image_file,
    pixel_hash,
    read_baseline,
    read_id_buffer,
    read_view_image,
)
from mrcheck.apps.regress.compare import ModeComparison, Tolerances, compare_images
from mrcheck.apps.regress.report import report_writes
from mrcheck.apps.regress.views import is_camera_file, resolve_views, split_views
from mrcheck.apps.regress.workers import render_views
from mrcheck.core.errors import MrcheckError
from mrcheck.core.output import check_not_inputs, check_own_output_dir, mark_output_dir, write_all_or_none
from mrcheck.core.progress import Progress, no_progress
from mrcheck.render.settings import MODES, RenderSettings
from mrcheck.scene.manifest import files_stamp, scene_files
from mrcheck.scene.model import load_scene

DEFAULT_MODES = ("phong", "vector")
DEFAULT_SIZE = (640, 480)  # width, height in pixels


@dataclass(frozen=True)
class ViewCheck:
    """One view checked: each mode's comparison, the pixels where the geometry changed (the ray
    cast id buffers, :func:`~mrcheck.apps.regress.attribution.geometry_changes`) with their
    limit, and the elements under the changed pixels."""

    name: str
    modes: list[ModeComparison]
    elements: list[ChangedElement] = field(default_factory=list)
    geometry_pixels: int = 0
    geometry_limit: int = 0

    @property
    def geometry_passed(self) -> bool:
        return self.geometry_pixels <= self.geometry_limit

    @property
    def passed(self) -> bool:
        return self.geometry_passed and all(m.passed for m in self.modes)

    def reasons(self) -> str:
        """Why the view changed: the modes over tolerance, the geometry."""
        why = [f"{m.mode}: {m.reason}" for m in self.modes if not m.passed]
        if not self.geometry_passed:
            why.append(f"geometry: {self.geometry_pixels} px hit other elements or depths > {self.geometry_limit}")
        return "; ".join(why)


@dataclass(frozen=True)
class CheckResult:
    """What ``regress check`` found and wrote."""

    baseline: Baseline
    scene: str  # the scene checked (absolute path)
    views: list[ViewCheck]
    report: Path
    written: list[Path]
    gl_renderer: str
    scene_stamp: str

    @property
    def passed(self) -> bool:
        return all(v.passed for v in self.views)

    @property
    def changed(self) -> list[ViewCheck]:
        return [v for v in self.views if not v.passed]

    def summary(self) -> list[str]:
        """One line per view, for the console."""
        lines = []
        for view in self.views:
            if view.passed:
                lines.append(f"ok       {view.name}")
                continue
            names = ", ".join(element_label(e) for e in view.elements[:5]) or "no element (background)"
            lines.append(f"CHANGED  {view.name}: {view.reasons()}; elements: {names}")
        return lines


def check_modes(modes) -> tuple[str, ...]:
    modes = tuple(dict.fromkeys(modes or DEFAULT_MODES))
    unknown = [m for m in modes if m not in MODES]
    if unknown:
        raise MrcheckError(f"unknown mode(s) {', '.join(unknown)} (use {', '.join(MODES)})")
    return modes


def record(
    scene,
    outdir,
    views=None,
    modes=DEFAULT_MODES,
    size: tuple[int, int] = DEFAULT_SIZE,
    settings: RenderSettings | None = None,
    progress: Progress = no_progress,
    workers: int = 1,
    client=None,
) -> Baseline:
    """Render ``views`` (default: the scene's viewpoints) in ``modes`` at ``size`` and write the
    baseline into ``outdir``: the images, the id buffers and baseline.json. ``workers`` local
    processes or the Dask cluster of ``client`` render the views (:mod:`.workers`)."""
    modes = check_modes(modes)
    settings = (settings or RenderSettings()).validated(size[1])
    outdir = check_own_output_dir(Path(outdir), "baseline folder")
    inputs = [("the scene", scene_files(scene)), ("--views", [v for v in split_views(views) if is_camera_file(v)])]
    loaded = load_scene(scene, progress=True)
    cameras = resolve_views(loaded, views, *size)
    outputs = [outdir / MANIFEST] + [outdir / image_file(n, m) for n, _ in cameras for m in modes]
    check_not_inputs(outputs, inputs)
    images, id_buffers, entries, gl_renderer = {}, {}, {}, ""
    for snap in render_views(scene, loaded, cameras, modes, settings, workers, client, progress):
        images.update({(snap.name, m): im for m, im in snap.images.items()})
        id_buffers[snap.name] = snap.ids
        files = {m: image_file(snap.name, m) for m in modes}
        entries[snap.name] = BaselineView(snap.name, snap.camera, files, {m: pixel_hash(snap.images[m]) for m in modes})
        gl_renderer = snap.gl_renderer
    baseline = Baseline(
        outdir.resolve(),
        __version__,
        gl_renderer,
        str(Path(scene).resolve()),
        files_stamp(scene_files(scene)),
        modes,
        size[0],
        size[1],
        settings,
        tuple(entries[name] for name, _ in cameras),  # the order asked for, not the order finished
    )
    stale = _previous_files(outdir)
    mark_output_dir(outdir)
    write_all_or_none(baseline_writes(baseline, images, id_buffers))
    _remove_stale(outdir, stale, baseline)
    return baseline


def _previous_files(outdir: Path) -> set[str]:
    """The files an earlier baseline in ``outdir`` listed (re-recording with fewer views leaves none behind)."""
    try:
        data = json.loads((outdir / MANIFEST).read_text())
        return {f for v in data["views"] for f in [*v["images"].values(), f"{v['name']}_ids.npz"]}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return set()


def _remove_stale(outdir: Path, stale: set[str], baseline: Baseline) -> None:
    kept = {f for v in baseline.views for f in [*v.images.values(), v.ids_file]}
    for name in stale - kept:
        if "/" not in name and not name.startswith("."):
            (outdir / name).unlink(missing_ok=True)


def check(
    scene,
    baseline_dir,
    outdir,
    tolerances: Tolerances | None = None,
    progress: Progress = no_progress,
    workers: int = 1,
    client=None,
) -> CheckResult:
    """Render the baseline's views of ``scene`` again with its settings, compare each mode with
    FLIP, name the elements under the changed pixels, and write the report into ``outdir``.
    ``workers``, ``client``: as for :func:`record`."""
    tolerances = tolerances or Tolerances()
    baseline = read_baseline(baseline_dir)
    check_files(baseline)
    outdir = check_own_output_dir(Path(outdir), "report folder")
    if outdir.resolve() == baseline.folder:
        raise MrcheckError("the report folder is the baseline folder; write the report elsewhere", outdir)
    baseline_files = [baseline.folder / MANIFEST] + [
        baseline.folder / f for v in baseline.views for f in v.images.values()
    ]
    report_files = [outdir / "report.html", outdir / "junit.xml"]
    check_not_inputs(report_files, [("the scene", scene_files(scene)), ("the baseline", baseline_files)])
    # every baseline image read (and its hash checked) before the scene loads: a bad one fails at once
    recorded = {v.name: {m: read_view_image(baseline, v, m) for m in baseline.modes} for v in baseline.views}
    loaded = load_scene(scene, progress=True)
    cameras = [(v.name, v.camera) for v in baseline.views]
    by_name = {v.name: v for v in baseline.views}
    found, pictures, gl_renderer = {}, {}, ""
    for snap in render_views(scene, loaded, cameras, baseline.modes, baseline.settings, workers, client, progress):
        view = by_name[snap.name]
        before = recorded[snap.name]
        modes = [compare_images(m, before[m], snap.images[m], tolerances) for m in baseline.modes]
        ids = read_id_buffer(baseline.folder / view.ids_file)
        moved = geometry_changes(ids, snap.ids)
        checked = ViewCheck(snap.name, modes, [], int(moved.sum()), int(tolerances.max_changed * moved.size))
        if not checked.passed:
            changed = np.logical_or.reduce([m.changed for m in modes] + [moved])
            checked = dataclasses.replace(checked, elements=attribute(changed, ids, snap.ids))
        found[snap.name] = checked
        pictures[snap.name] = (before, snap.images)
        gl_renderer = snap.gl_renderer
    checks = [found[v.name] for v in baseline.views]  # the baseline's order, not the order finished
    stamp = files_stamp(scene_files(scene))
    mark_output_dir(outdir)
    checked = str(Path(scene).resolve())
    result = CheckResult(baseline, checked, checks, outdir / "report.html", [], gl_renderer, stamp)
    written = write_all_or_none(report_writes(outdir, result, pictures, tolerances))
    return CheckResult(baseline, checked, checks, outdir / "report.html", written, gl_renderer, stamp)


__all__ = ["record", "check", "CheckResult", "ViewCheck", "DEFAULT_MODES", "DEFAULT_SIZE"]
