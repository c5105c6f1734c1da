"""``mrcheck regress diff OLD NEW -o REPORT/``: load both revisions, compare them element by
element, draw each view, then write every output at once (all or none).

Outputs in REPORT::

    changes.csv, changes.json   every element: added, removed, moved (offset, rotation),
                                changed geometry, unchanged (:mod:`~mrcheck.apps.modeldiff.report`)
    view-NAME.png               per view: NEW in vector AO with the changes drawn over it
                                (:mod:`~mrcheck.apps.modeldiff.picture`)
    changes.bcfzip              with ``bcf``: one BCF 2.1 topic per change

OLD and NEW are read by :func:`~mrcheck.apps.modeldiff.revisions.load_revisions`: a glTF file by its
nodes, anything else as every command reads a scene. The views are NEW's viewpoints (else
OLD's; else one overview of NEW), or those named.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from mrcheck.apps.bcf import ifc_file_of
from mrcheck.apps.modeldiff.compare import TOLERANCE_DEG, TOLERANCE_M, ModelDiff, diff_scenes
from mrcheck.apps.modeldiff.picture import Painter, ViewPicture
from mrcheck.apps.modeldiff.report import CHANGES_BCF, CHANGES_CSV, CHANGES_JSON, changes_bcf, changes_csv, changes_json
from mrcheck.apps.modeldiff.revisions import load_revisions
from mrcheck.core.errors import MrcheckError
from mrcheck.core.images import encode_image
from mrcheck.core.output import (
    check_not_inputs,
    check_own_output_dir,
    mark_output_dir,
    write_all_or_none,
    writer,
)
from mrcheck.core.progress import Progress, no_progress
from mrcheck.scene.manifest import scene_files
from mrcheck.scene.model import Scene

DEFAULT_WIDTH = 800  # pixels of each view's picture (its height keeps the viewpoint's aspect)


@dataclass(frozen=True)
class DiffSettings:
    """What ``regress diff`` is asked for besides its inputs."""

    views: tuple = ()  # viewpoint names; () = every viewpoint
    width: int = DEFAULT_WIDTH
    bcf: bool = False
    pictures: bool = True
    tolerance_m: float = TOLERANCE_M
    tolerance_deg: float = TOLERANCE_DEG


@dataclass(frozen=True)
class DiffRun:
    """What was compared and written. ``exit_code``: 0 without changes, 1 with any."""

    outdir: Path
    diff: ModelDiff
    written: list = field(default_factory=list)

    @property
    def exit_code(self) -> int:
        return 1 if self.diff.changes else 0

    @property
    def summary(self) -> str:
        counts = ", ".join(f"{n} {kind}" for kind, n in self.diff.counts.items())
        return f"regress diff: {len(self.diff.rows)} elements: {counts}"


def picture_name(view: str, taken: set) -> str:
    """``view-NAME.png`` with NAME made file-safe (and numbered when two views would share it)."""
    stem = "view-" + (re.sub(r"[^A-Za-z0-9._-]+", "_", view).strip("._") or "view")
    name, n = f"{stem}.png", 2
    while name in taken:
        name, n = f"{stem}-{n}.png", n + 1
    taken.add(name)
    return name


def view_cameras(old: Scene, new: Scene, settings: DiffSettings) -> dict:
    """{view name: camera} of the pictures (module docstring)."""
    from mrcheck.apps.deviation.element_image import overview_camera

    source = new if new.viewpoints or not old.viewpoints else old
    names = list(settings.views) or list(source.viewpoints)
    missing = [v for v in names if v not in source.viewpoints]
    if missing:
        known = ", ".join(source.viewpoints) or "none"
        raise MrcheckError(f"no viewpoint named {missing[0]!r} (the scene has: {known})", source.source)
    if not names:
        camera = overview_camera(new)
        return {"overview": camera.resized(settings.width, round(camera.height * settings.width / camera.width))}
    return {name: source.camera(name, settings.width) for name in names}


def draw_views(old: Scene, new: Scene, diff: ModelDiff, cameras: dict, progress: Progress) -> list[ViewPicture]:
    """The picture of every view, on one GL context."""
    import contextlib

    from mrcheck.render.gl import create_context

    ctx = create_context()
    try:
        painter = Painter(old, new, diff, ctx)
        try:
            with contextlib.closing(progress(list(cameras.items()), "drawing views", "view")) as bar:
                return [painter.view(name, camera) for name, camera in bar]
        finally:
            painter.release()
    finally:
        ctx.release()


def diff_command(
    old_path, new_path, outdir, settings: DiffSettings = DiffSettings(), progress: Progress = no_progress
) -> DiffRun:
    """Check the inputs and REPORT, load, compare, draw, write (module docstring)."""
    outdir = Path(outdir)
    fixed = [CHANGES_CSV, CHANGES_JSON, *((CHANGES_BCF,) if settings.bcf else ())]
    inputs = [("OLD", scene_files(old_path)), ("NEW", scene_files(new_path))]
    check_not_inputs([outdir / n for n in fixed], inputs)
    check_own_output_dir(outdir)
    old, new = load_revisions(Path(old_path), Path(new_path))
    diff = diff_scenes(old, new, settings.tolerance_m, settings.tolerance_deg)
    cameras = view_cameras(old, new, settings) if settings.pictures else {}
    taken: set = set(fixed)
    names = {view: picture_name(view, taken) for view in cameras}
    check_not_inputs([outdir / n for n in names.values()], inputs)
    pictures = draw_views(old, new, diff, cameras, progress) if cameras else []
    views = {p.name: {"file": names[p.name], "changes": sorted(p.boxes)} for p in pictures}
    outputs: dict = {CHANGES_CSV: changes_csv(diff), CHANGES_JSON: changes_json(diff, views)}
    pngs = {p.name: encode_image(names[p.name], p.image) for p in pictures}
    outputs.update({names[name]: png for name, png in pngs.items()})
    if settings.bcf:
        key = str(outdir.resolve())
        outputs[CHANGES_BCF] = changes_bcf(diff, pictures, pngs, key, new.name, ifc_file_of(new))
    mark_output_dir(outdir)
    written = write_all_or_none([writer(outdir / name, content) for name, content in outputs.items()])
    return DiffRun(outdir, diff, written)


__all__ = ["diff_command", "DiffRun", "DiffSettings", "DEFAULT_WIDTH", "picture_name", "view_cameras"]
