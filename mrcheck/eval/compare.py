"""``mrcheck compare``: every AO mode against the ray-traced reference AO with the same definition.

For one scene view, each AO mode of :data:`mrcheck.render.renderer.MODES` (all but ``phong``) is
rendered twice with the same settings: blurred, as a planner sees it (the shaded image), and
unblurred (``blur=False``), the raw estimate the metrics judge, whose AO pass time is recorded.
Each mode is judged against the reference of its own radius definition
(:func:`mrcheck.eval.reference.reference_ao`):

* ``vector``, ``gtao``, ``vbao`` -- ``radius_mode="screen"`` with the render's ``radius_px`` (per
  pixel ``r_S = r_px * Z / f_y``); these share one screen reference;
* every other mode -- ``radius_mode="world"`` with the render's ``radius_world``; these modes
  share one world reference, computed once.

Both references use the render's falloff and the depth and normals of the render's G-buffer, so
a difference is the screen-space approximation, not a different AO definition or surface.

Outputs in OUTDIR, written atomically, all or none: ``figure.png`` (the reference rows, then
per mode: shaded | AO | signed error ``ao - reference``), ``metrics.json`` and ``metrics.md``
(the metrics of :mod:`mrcheck.eval.metrics`, the AO pass time, and rankings computed from them).
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np

from mrcheck.core.errors import MrcheckError, MrcheckWarning
from mrcheck.core.output import (
    check_not_inputs,
    check_output_dir,
    labelled_sheet,
    write_all_or_none,
    write_image,
    write_text,
)
from mrcheck.eval.metrics import (
    METRIC_NAMES,
    MetricUndefined,
    all_metrics,
    covered,
    distance_retention,
)
from mrcheck.render.renderer import MODES, STUDY_LABELS, Renderer, RenderSettings
from mrcheck.render.settings import SCREEN_RADIUS_MODES
from mrcheck.scene.manifest import scene_files
from mrcheck.scene.model import load_scene

ERROR_SCALE = 0.5  # the error map saturates at |ao - reference| = 0.5
NEGATIVE_RGB = np.array([33, 84, 200.0])  # ao darker than the reference (invented occlusion)
POSITIVE_RGB = np.array([205, 35, 35.0])  # ao lighter than the reference (missed occlusion)
BACKGROUND_RGB = np.array([70, 90, 110.0])  # no surface: no AO, no error (slate, not a grey level)
FIGURE_NAME, JSON_NAME, MD_NAME = "figure.png", "metrics.json", "metrics.md"

# metric -> (column title, True when larger is better); the order of the tables and rankings
COLUMNS = {
    "mae": ("MAE", False),
    "rmse": ("RMSE", False),
    "ssim": ("SSIM", True),
    "false_occlusion": ("false occlusion", False),
    "distance_retention": ("distance retention", True),
    "ms": ("AO pass ms", False),
}


def reference_kind(mode: str) -> str:
    """``"screen"`` for the screen-radius modes (vector, gtao, vbao), ``"world"`` for every other AO mode."""
    return "screen" if mode in SCREEN_RADIUS_MODES else "world"


@dataclass
class Reference:
    """A ray-traced reference AO and how the figure and the report name it."""

    ao: np.ndarray
    short: str = ""  # "screen 1.4 px", "world 0.2"
    label: str = ""  # "screen radius 1.4 px, 256 rays"
    distance_retention: float | None = None  # its own, which the modes' is compared with


@dataclass
class ModeRow:
    """One AO mode's renders and metrics (a figure row, a table row)."""

    mode: str
    kind: str  # the reference it is judged against: "screen" or "world"
    image: np.ndarray  # the shaded (blurred) render
    ao: np.ndarray  # the unblurred AO buffer
    ms: float  # its AO pass time
    metrics: dict  # all_metrics against the reference


# -- figure ----------------------------------------------------------------------------------------
def legend_strip_height(h: int) -> int:
    """Height (px) of the error-scale strip under each panel of a figure whose renders are ``h`` high."""
    return max(6, h // 14)


def _grey(ao: np.ndarray, mask: np.ndarray) -> np.ndarray:
    out = np.repeat((np.clip(ao, 0.0, 1.0) * 255.0)[..., None], 3, axis=2)
    out[~mask] = BACKGROUND_RGB
    return np.round(out).astype(np.uint8)


def _diverging(t: np.ndarray) -> np.ndarray:
    """(..., 3) uint8 for ``t`` in [-1, 1]: blue at -1, white at 0, red at +1."""
    t = np.clip(t, -1.0, 1.0)[..., None]
    white = np.full(3, 255.0)
    rgb = white + np.abs(t) * (np.where(t < 0, NEGATIVE_RGB, POSITIVE_RGB) - white)
    return np.round(rgb).astype(np.uint8)


def _error_map(ao: np.ndarray, ref: np.ndarray, mask: np.ndarray) -> np.ndarray:
    out = _diverging((ao - ref) / ERROR_SCALE)
    out[~mask] = BACKGROUND_RGB
    return out


def _text(image, text, origin, scale, color=(235, 235, 235)):
    cv2.putText(image, text, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, color, 1, cv2.LINE_AA)


def _legend_strip(width: int, height: int) -> np.ndarray:
    """A colour bar of the error scale, -0.5 (left) to +0.5 (right), with its end values."""
    strip = np.repeat(_diverging(np.linspace(-1.0, 1.0, width))[None], height, axis=0)
    scale = height / 30.0
    if scale >= 0.25:  # too small to read below that; the colours still say it
        y = int(height * 0.75)
        _text(strip, f"-{ERROR_SCALE:g}", (2, y), scale, (255, 255, 255))
        right = f"+{ERROR_SCALE:g}"
        (text_w, _), _ = cv2.getTextSize(right, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
        _text(strip, right, (width - text_w - 2, y), scale, (255, 255, 255))
        _text(strip, "0", (width // 2 - int(height * 0.2), y), scale, (40, 40, 40))
    return strip


def _with_strip(panel: np.ndarray, strip: np.ndarray | None, height: int) -> np.ndarray:
    """``panel`` over ``strip`` (or over an empty bar, so every panel of a row has one height)."""
    if strip is None:
        strip = np.full((height, panel.shape[1], 3), 32, np.uint8)
    return np.vstack([panel, strip])


def _legend_panel(h: int, w: int, judged: list[str]) -> np.ndarray:
    """The third panel of a reference row: the error colour scale, and the modes judged here."""
    panel = np.full((h, w, 3), 32, np.uint8)
    bar_h = max(6, h // 8)
    top = h // 2 - bar_h // 2
    panel[top : top + bar_h, w // 10 : w - w // 10] = _diverging(np.linspace(-1.0, 1.0, w - 2 * (w // 10)))[None]
    scale = max(0.25, h / 500.0)
    line = max(8, int(h / 12))
    _text(panel, f"error = AO - reference, +-{ERROR_SCALE:g}", (w // 20, top - 2 * line), scale)
    _text(panel, "blue: darker than reference", (w // 20, top - line), scale)
    _text(panel, "red: lighter than reference", (w // 20, top + bar_h + line), scale)
    _text(panel, "judges: " + ", ".join(judged), (w // 20, top + bar_h + 2 * line), scale)
    return panel


def build_figure(phong, references: dict, rows: list, mask, rays: int) -> np.ndarray:
    """The comparison figure (``references``: kind -> :class:`Reference`, ``rows``: :class:`ModeRow`): one labelled
    row per reference (Phong image, reference AO, the
    error legend), then one per mode (shaded image, AO, signed error map with a legend strip)."""
    h, w = mask.shape
    strip_h = legend_strip_height(h)
    strip = _legend_strip(w, strip_h)
    sheets = []
    for kind, ref in references.items():
        judged = [row.mode for row in rows if row.kind == kind]
        panels = [phong, _grey(ref.ao, mask), _legend_panel(h, w, judged)]
        labels = ["D1 Phong (no AO)", f"reference, {ref.short}", f"error scale ({rays} ref. rays)"]
        sheets.append(labelled_sheet([_with_strip(p, None, strip_h) for p in panels], labels))
    for row in rows:
        ref = references[row.kind].ao
        panels = [
            _with_strip(row.image, None, strip_h),
            _with_strip(_grey(row.ao, mask), None, strip_h),
            _with_strip(_error_map(row.ao, ref, mask), strip, strip_h),
        ]
        name = STUDY_LABELS.get(row.mode, row.mode)
        sheets.append(
            labelled_sheet(
                panels, [f"{name}: shaded", f"{row.mode}: AO (no blur)", f"{row.mode} - {row.kind} reference"]
            )
        )
    return np.vstack(sheets)


# -- tables ----------------------------------------------------------------------------------------
def _fmt(value) -> str:
    if value is None:
        return "n/a"
    return f"{value:.1f}" if abs(value) >= 100 else f"{value:.4f}" if abs(value) < 10 else f"{value:.2f}"


def _table_rows(modes: dict) -> list[list[str]]:
    header = ["mode", *(title for title, _ in COLUMNS.values()), "reference"]
    body = [[mode, *(_fmt(m[key]) for key in COLUMNS), m["reference"]] for mode, m in modes.items()]
    return [header, *body]


def rankings(modes: dict) -> list[str]:
    """One statement per column, computed from the numbers: best and worst mode, and the full
    order (modes whose value is undefined are named apart)."""
    statements = []
    for key, (title, larger_better) in COLUMNS.items():
        defined = [(m[key], mode) for mode, m in modes.items() if m[key] is not None]
        if not defined:
            statements.append(f"{title}: undefined for every mode")
            continue
        # best first; ties keep the MODES order
        ordered = sorted(defined, key=lambda vm: -vm[0] if larger_better else vm[0])
        best, worst = ("highest", "lowest") if larger_better else ("lowest", "highest")
        text = f"{best} {title}: {ordered[0][1]} ({_fmt(ordered[0][0])})"
        if len(ordered) > 1:
            text += f"; {worst}: {ordered[-1][1]} ({_fmt(ordered[-1][0])}); order: " + (
                " > " if larger_better else " < "
            ).join(mode for _, mode in ordered)
        missing = [mode for mode, m in modes.items() if m[key] is None]
        if missing:
            text += f" (undefined: {', '.join(missing)})"
        statements.append(text)
    return statements


def _ratio_statements(modes: dict) -> list[str]:
    """Distance retention of every world-radius mode relative to vector, when both are defined."""
    vector = modes.get("vector", {}).get("distance_retention")
    out = []
    for mode, m in modes.items():
        if mode != "vector" and vector is not None and m["distance_retention"]:
            out.append(f"distance retention vector / {mode}: {vector / m['distance_retention']:.2f}x")
    return out


def markdown(report: dict) -> str:
    rows = _table_rows(report["modes"])
    lines = [
        f"# AO modes against ray-traced reference AO: {Path(report['scene']).name}, view {report['view']}",
        "",
        f"{report['width']}x{report['height']}, {report['samples']} AO samples per pixel, "
        f"{report['rays']} reference rays per pixel; "
        f"screen radius (vector, gtao, vbao) {report['radius_px']:.2f} px (screen "
        f"reference), world radius {report['radius_world']:g} (world reference), falloff {report['falloff']:g}. "
        "Metrics on the unblurred AO over covered pixels; AO pass time of the unblurred render.",
        "",
        "| " + " | ".join(rows[0]) + " |",
        "|" + "---|" * len(rows[0]),
    ]
    lines += ["| " + " | ".join(r) + " |" for r in rows[1:]]
    lines += ["", "## Rankings", ""] + [
        f"- {s}" for s in rankings(report["modes"]) + _ratio_statements(report["modes"])
    ]
    lines += ["", "## References", ""]
    lines += [
        f"- {kind}: {ref['label']}; its own distance retention {_fmt(ref['distance_retention'])}"
        for kind, ref in report["references"].items()
    ]
    notes = [
        f"- {mode} {metric}: {reason}"
        for mode, reasons in report["notes"].items()
        for metric, reason in reasons.items()
    ]
    if notes:
        lines += ["", "## Undefined metrics", "", *notes]
    return "\n".join(lines) + "\n"


def table_lines(modes: dict) -> list[str]:
    """The metrics table as aligned console lines (mode left, numbers right)."""
    rows = _table_rows(modes)
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return [
        "  ".join(cell.rjust(width) if i else cell.ljust(width) for i, (cell, width) in enumerate(zip(r, widths)))
        for r in rows
    ]


# -- the command -----------------------------------------------------------------------------------
PROGRESS_STAGE = "comparing"  # the stage compare_command reports its modes under


@dataclass(frozen=True)
class ComparisonRun:
    """What ``mrcheck compare`` measured (``report`` is ``metrics.json``) and the files written."""

    report: dict
    paths: list[Path]  # figure.png, metrics.json, metrics.md

    def table(self) -> list[str]:
        """The metrics table for the console."""
        return table_lines(self.report["modes"])


def _reference(scene, camera, depth, normals, rays, kind, settings, progress) -> np.ndarray:
    from mrcheck.eval.reference import (
        reference_ao,  # imports Open3D: only when a comparison runs
    )

    radius = settings.radius_px if kind == "screen" else settings.radius_world
    return reference_ao(
        scene,
        camera,
        depth,
        normals,
        rays,
        kind,
        radius,
        falloff=settings.falloff,
        seed=settings.seed,
        progress=progress,
    )


def _render_and_judge(renderer, loaded, camera, settings, rays, progress):
    """(phong image, depth, references by kind, mode rows): every AO mode rendered blurred and
    unblurred, judged against the reference of its radius definition (computed once per kind)."""
    frame = renderer.render(camera, ["phong"], settings, want_normals=True)
    phong, depth, normals = frame["phong"].image, frame.depth, frame.normals
    ao_modes = [m for m in MODES if m != "phong"]
    references, rows = {}, []
    if progress is not None:
        progress(PROGRESS_STAGE, 0, len(ao_modes))
    for done, mode in enumerate(ao_modes):
        # the blurred render first: it also builds the mode's AO program, so the timed pass
        # of the unblurred render below is the AO work alone, not shader compilation
        shaded = renderer.render(camera, [mode], settings)[mode].image
        raw = renderer.render(camera, [mode], replace(settings, blur=False), want_ao=True)[mode]
        kind = reference_kind(mode)
        if kind not in references:  # one reference per radius definition, shared by its modes
            references[kind] = Reference(_reference(loaded, camera, depth, normals, rays, kind, settings, progress))
        rows.append(
            ModeRow(mode, kind, shaded, raw.ao, raw.timings_ms["ao"], all_metrics(raw.ao, references[kind].ao, depth))
        )
        if progress is not None:
            progress(PROGRESS_STAGE, done + 1, len(ao_modes))
    return phong, depth, references, rows


def _label_references(references: dict, settings, rays: int, depth) -> None:
    """Each reference's labels and its own distance retention (the value the modes' is compared with)."""
    for kind, ref in references.items():
        ref.short = f"screen {settings.radius_px:.1f} px" if kind == "screen" else f"world {settings.radius_world:g}"
        ref.label = f"{ref.short.replace(' ', ' radius ', 1)}, {rays} rays"
        try:
            ref.distance_retention = distance_retention(ref.ao, ref.ao, depth)
        except MetricUndefined:
            ref.distance_retention = None


def _report(scene, view, camera, samples, rays, settings, references: dict, rows: list[ModeRow]) -> dict:
    """``metrics.json``."""
    modes = {
        row.mode: {**{k: row.metrics[k] for k in METRIC_NAMES}, "ms": row.ms, "reference": row.kind} for row in rows
    }
    return {
        "scene": str(Path(scene).resolve()),
        "view": view,
        "width": camera.width,
        "height": camera.height,
        "samples": samples,
        "rays": rays,
        "modes": modes,
        "radius_px": settings.radius_px,
        "radius_world": settings.radius_world,
        "falloff": settings.falloff,
        "references": {
            k: {"radius_mode": k, "label": r.label, "distance_retention": r.distance_retention}
            for k, r in references.items()
        },
        "notes": {row.mode: row.metrics["notes"] for row in rows if row.metrics["notes"]},
    }


def compare_command(scene, view, samples, rays, width, height, outdir, progress=None) -> ComparisonRun:
    """Render every AO mode of ``scene`` from ``view``, compare each with its reference, write
    ``figure.png``, ``metrics.json`` and ``metrics.md`` into ``outdir``. An undefined metric is
    warned about (``MrcheckWarning``); ``progress(stage, done, total)`` hears of the modes
    (:data:`PROGRESS_STAGE`) and of the references' rays."""
    from mrcheck.eval.reference import MAX_RAYS, REFERENCE_LOD_PX

    outdir = check_output_dir(outdir)
    check_not_inputs([outdir / name for name in (FIGURE_NAME, JSON_NAME, MD_NAME)], [("the scene", scene_files(scene))])
    if not 1 <= rays <= MAX_RAYS:
        raise MrcheckError(f"rays must be in [1, {MAX_RAYS}], got {rays}")
    loaded = load_scene(scene, progress=True)
    camera = loaded.camera(view, width, height)
    # full detail: the references are ray-traced on the full-detail scene (REFERENCE_LOD_PX)
    # single-sampled: the AO is judged on the G-buffer the reference's rays start from, every pixel
    # a point of the surface its centre sees (an anti-aliased frame's edge pixels hold the majority
    # surface's plane at the centre, which may lie just off that surface's triangle)
    settings = RenderSettings(samples=samples, lod_px=REFERENCE_LOD_PX, antialias=False).validated(camera.height)
    renderer = Renderer(loaded)
    try:
        phong, depth, references, rows = _render_and_judge(renderer, loaded, camera, settings, rays, progress)
    finally:
        renderer.release()
    _label_references(references, settings, rays, depth)
    report = _report(scene, view, camera, samples, rays, settings, references, rows)
    for mode, reasons in report["notes"].items():
        for metric, reason in reasons.items():
            warnings.warn(MrcheckWarning(f"{mode} {metric} undefined: {reason}"))

    figure = build_figure(phong, references, rows, covered(depth), rays)
    text = json.dumps(report, indent=2) + "\n"
    writes = [
        lambda: write_image(outdir / FIGURE_NAME, figure),
        lambda: write_text(outdir / JSON_NAME, text),
        lambda: write_text(outdir / MD_NAME, markdown(report)),
    ]
    return ComparisonRun(report, list(write_all_or_none(writes)))


__all__ = [
    "compare_command",
    "ComparisonRun",
    "Reference",
    "ModeRow",
    "build_figure",
    "rankings",
    "markdown",
    "table_lines",
    "reference_kind",
    "legend_strip_height",
    "ERROR_SCALE",
    "PROGRESS_STAGE",
]
