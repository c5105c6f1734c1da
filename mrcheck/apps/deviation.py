"""``mrcheck deviation``: as-built vs as-planned from a laser scan (cloud-to-mesh distances).

For every scan point ``p`` the closest point ``c`` on the planned CAD (every part, every
instance; Open3D's ``RaycastingScene.compute_closest_points``) and that triangle's normal ``n``
give the **signed distance**::

    d(p) = sign((p - c) . n) * |p - c|      (metres; > 0 outside / in front of the CAD surface)

The sign comes from the closest triangle's normal, not from an inside/outside test
(``compute_signed_distance``): that one needs watertight meshes, and CAD exports are open
shells, single-sided plates and overlapping parts, where "inside" is not defined. The normal
follows the triangle's winding (counter-clockwise = front), so a mesh with flipped faces
flips the sign of its points; the magnitude is always right. This is what CloudCompare's C2M
("cloud to mesh") distance does with its "signed distances" option.

Per part instance (:attr:`mrcheck.scene.model.Part.instance_ids`) the points whose closest triangle
belongs to it give: ``points`` (how many), ``median_abs``, ``mean_abs``, ``p95_abs`` (95th
percentile of ``|d|``), ``signed_mean`` and ``signed_median``. Instances are ranked by
``median_abs`` (robust to a few stray points: a part that is out of place has most of its
points off); instances no scan point is closest to come last (not scanned, or missing).

Outputs in OUTDIR, all written atomically and only after every check has passed::

    deviations.npy       float32 (N,) signed distance of every scan point, metres, scan order
    parts.json, parts.md the ranked per-instance list
    deviation_top.png    top-down orthographic splat of the scan coloured by d, with a legend
    deviation_side.png   the same seen from the front (-y), z up
    deviation_render.png with --shot: the scan projected through the shot's camera (with its
    deviation_overlay.png lens distortion) over the CAD render / the photo-and-CAD overlay

Colours: a diverging map, blue (d < 0, behind the CAD surface) - white (0) - red (d > 0,
in front of it), symmetric about 0 and saturating at +-S, S the 95th percentile of ``|d|``
rounded up to 1, 2 or 5 x 10^k mm; the legend bar gives the scale in mm.

Scan formats: ``.ply`` and ``.pcd`` through ``open3d.io.read_point_cloud``; ``.xyz``, ``.txt``,
``.pts`` as header-less text ``x y z [...]`` per line (separated by white space, commas or
semicolons; no decimal commas). A ``.ply`` without the ``ply`` magic on
its first line is read as text too (the Stanford bunny's range scans are such files). ``--units``
scales the scan to metres; the scene is loaded as its manifest says.

Sanity checks (one-line error, nothing written): a missing, empty or unreadable file, an
unsupported format, no points, NaN/infinite points, a scan whose bounding box is far larger than
the scene's (wrong units: the unit that would fit is named), a scan whose bounding box does not
overlap the scene's, or whose median distance to the CAD exceeds twice its own extent, or twice
2 % of the scene's diagonal or 1 cm if more (not registered, or wrong units; a single point or a
small patch has almost no extent of its own).

Precision: Open3D queries in float32, and a hall may sit 1e6 m from the origin, so the CAD
triangle soup (:mod:`mrcheck.eval.reference`) and the scan points are both taken relative to the
scan's bounding-box centre in float64 before they become float32 (the scene's centre would
lie halfway to a stray element far away).
"""

from __future__ import annotations

import io
import json
import math
import re
import sys
from pathlib import Path

import cv2
import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.core.inputs import check_input
from mrcheck.core.output import (
    check_not_inputs,
    check_output_dir,
    write_all_or_none,
    write_bytes,
    write_image,
    write_text,
)
from mrcheck.core.quiet import native_output
from mrcheck.scene.manifest import scene_files
from mrcheck.scene.model import UNITS, Scene, unit_scale

SCAN_SUFFIXES = (".ply", ".pcd", ".xyz", ".txt", ".pts")
# the files written into OUTDIR (module docstring); the last two with --shot only
DEVIATIONS, PARTS_JSON, PARTS_MD = "deviations.npy", "parts.json", "parts.md"
VIEW_IMAGES = {"top": "deviation_top.png", "side": "deviation_side.png"}
SHOT_IMAGES = {"deviation_render.png": 0.0, "deviation_overlay.png": 0.5}   # name: the photo's alpha
QUERY_CHUNK = 1 << 20            # points per closest-point query (~100 MB of results)
UNIT_RATIO_LIMIT = 20.0          # scan bbox diagonal / scene bbox diagonal beyond which units are wrong
OVERLAP_MARGIN = 0.05            # bbox overlap test tolerance, as a share of the scene diagonal
FAR_FACTOR = 2.0                 # median |d| > FAR_FACTOR * the size below: not registered
# the size a scan's median distance is judged against is at least this share of the scene's
# diagonal, and at least FAR_FLOOR_M: a single point or a small patch has a diagonal near 0, and
# one real bunny point 1.2 mm off the mesh was refused as "not registered"
FAR_SCENE_SHARE = 0.02
FAR_FLOOR_M = 0.01
IMAGE_SIZE = 1024                # longest side of the orthographic images, pixels
SPLAT_RADIUS = 1                 # splat half-size in pixels (3x3 squares)
BACKGROUND = (40, 40, 40)
# diverging control points (ColorBrewer RdBu, reversed so that + is red), from -1 to +1
_RDBU = np.array([[5, 48, 97], [33, 102, 172], [67, 147, 195], [146, 197, 222], [209, 229, 240], [247, 247, 247],
                  [253, 219, 199], [244, 165, 130], [214, 96, 77], [178, 24, 43], [103, 0, 31]], np.float64)


# -- reading the scan -----------------------------------------------------------------------------
def _is_ply_binary_or_header(path: Path) -> bool:
    with open(path, "rb") as handle:
        return handle.read(3) == b"ply"


def read_scan(path, units: str | None = None) -> np.ndarray:
    """(N, 3) float64 scan points in metres; every bad-input case raises :class:`MrcheckError`."""
    path = Path(path)
    size = check_input(path, "scan file").st_size
    suffix = path.suffix.lower()
    if suffix not in SCAN_SUFFIXES:
        raise MrcheckError(f"unsupported scan format {suffix or '(none)'} (use {', '.join(SCAN_SUFFIXES)})", path)
    if size == 0:
        raise MrcheckError("scan file is empty (no points)", path)
    scale = unit_scale(units, path)
    try:
        # sniff, do not trust the suffix: header-less "x y z" files are often named .ply
        if suffix == ".pcd" or (suffix == ".ply" and _is_ply_binary_or_header(path)):
            points = _read_cloud(path, suffix[1:])
        else:
            points = _read_text(path)
    except MrcheckError:
        raise
    except Exception as exc:  # the readers raise many types for corrupt files
        reason = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise MrcheckError(f"cannot read scan ({reason})", path) from None
    points = points.reshape(-1, 3)
    if len(points) == 0:
        raise MrcheckError("scan has no points (empty or unreadable cloud)", path)
    bad = ~np.all(np.isfinite(points), axis=1)
    if bad.any():
        raise MrcheckError(f"scan has {int(bad.sum())} points with NaN or infinite coordinates", path)
    return points * scale


def _read_cloud(path: Path, fmt: str) -> np.ndarray:
    """Points of a .ply / .pcd through Open3D, which reports a corrupt or truncated file only by
    printing (RPly's "Error reading 'x' of 'vertex' number 20125", then "Read PLY failed") and
    returns the cloud anyway, the unread points left as garbage: its output is captured (RPly's C
    library writes to the file descriptors, Open3D's warnings go through Python's sys.stdout) and
    a failure becomes the error."""
    import open3d as o3d

    with native_output(fds=(1, 2), python=True) as messages:
        cloud = o3d.io.read_point_cloud(str(path), format=fmt, remove_nan_points=False, remove_infinite_points=False)
    failed = [line for line in messages if "failed" in line.lower() or "error" in line.lower()]
    if failed:
        raise MrcheckError(f"cannot read scan, corrupt or truncated ({failed[0]})", path)
    return np.asarray(cloud.points, np.float64)


# values are separated by white space, commas (CloudCompare's ASCII export writes x,y,z) or
# semicolons. Decimal commas are told apart by counting fields: "1,25 2,50 0,10" is three
# white-space fields with a comma inside each, which "1,2,3" and "1, 2, 3" never are (split at
# both, it was the six numbers 1, 25, 2, 50, 0, 10 and the point (1, 25, 2)). A line with a
# semicolon is split at semicolons only, so that "1,5;2,5;0,0" is refused, not read as (1, 5, 2).
_SEMICOLONS = re.compile(r"[\s;]+")
_COMMENTS = ("#", "//")


def _values(line: str) -> list[str] | None:
    """The values of one line, or None for a line with decimal commas."""
    if ";" in line:
        return [v for v in _SEMICOLONS.split(line.strip()) if v]
    if "," not in line:
        return line.split()
    fields = [f.strip() for f in line.split(",")]
    if any(len(f.split()) > 1 for f in fields):   # white space inside a comma-separated field
        return None
    return [f for f in fields if f]


def _text_problem(lines) -> str:
    """Why the first bad one of ``(line number, line)`` is not ``x y z``: decimal commas or non-numbers."""
    for number, line in lines:
        values = _values(line)
        if values is None or any("," in v for v in values[:3]):
            return f"line {number} {line.strip()[:60]!r}: decimal commas are not supported"
        try:
            [float(v) for v in values[:3]]
        except ValueError:
            return f"line {number} {line.strip()[:60]!r}: not numbers"
    return "a line with non-numbers"


def _read_text(path: Path) -> np.ndarray:
    """Header-less ``x y z [more columns]`` lines, separated by white space, commas or semicolons.
    Lines with fewer than three values are skipped with a warning: header-stripped Stanford range
    scans keep their range-grid lines ("0", "1 17") after the points."""
    try:
        text = path.read_text(encoding="ascii")
    except UnicodeDecodeError:
        raise MrcheckError("not a text x y z point file (binary content)", path) from None
    lines = [(n, line) for n, line in enumerate(text.splitlines(), 1)
             if line.strip() and not line.lstrip().startswith(_COMMENTS)]
    rows = [_values(line) for _, line in lines]
    points = [r[:3] for r in rows if r is not None and len(r) >= 3]
    try:
        if None in rows:
            raise ValueError("decimal commas")
        data = np.array(points, np.float64).reshape(-1, 3)   # "nan" parses: caught as NaN below
    except ValueError:
        raise MrcheckError(f"not a text x y z point file ({_text_problem(lines)})", path) from None
    if len(points) < len(rows):
        print(f"warning: {path}: skipped {len(rows) - len(points)} lines with fewer than 3 values", file=sys.stderr)
    return data


# -- checks -------------------------------------------------------------------------------------------
def _diagonal(bounds) -> float:
    return float(np.linalg.norm(bounds[1] - bounds[0]))


def check_placement(points: np.ndarray, scene: Scene, path) -> tuple[float, float]:
    """Wrong units or a scan far from the scene, from the bounding boxes alone (cheap, first);
    returns the diagonals of the scan's and the scene's boxes (metres), which the later
    "not registered" check also needs."""
    scan_box = np.stack([points.min(axis=0), points.max(axis=0)])
    scene_box = scene.bounds()
    scan_diag, scene_diag = _diagonal(scan_box), max(_diagonal(scene_box), 1e-9)
    ratio = scan_diag / scene_diag
    if ratio > UNIT_RATIO_LIMIT:
        # the unit whose scaling brings the scan closest to the scene's size (a scan covers at most it)
        guess = min((u for u in UNITS if UNITS[u] < 1.0), key=lambda u: abs(math.log(ratio * UNITS[u])))
        raise MrcheckError(f"the scan is {ratio:.0f}x the scene's size: the scan looks like "
                           f"{_UNIT_WORDS[guess]}; pass --units {guess}", path)
    margin = OVERLAP_MARGIN * scene_diag
    gap = np.maximum(0.0, np.maximum(scene_box[0] - margin - scan_box[1], scan_box[0] - scene_box[1] - margin))
    if np.any(gap > 0.0):
        _far(float(np.linalg.norm(np.maximum(0.0, np.maximum(scene_box[0] - scan_box[1], scan_box[0] - scene_box[1])))), path)
    return scan_diag, scene_diag


_UNIT_WORDS = {"mm": "millimetres", "cm": "centimetres", "in": "inches", "ft": "feet", "m": "metres"}


def _far(metres: float, path):
    raise MrcheckError(f"the scan is {metres:.3g} m away from the scene: wrong units or not registered", path)


# -- distances ----------------------------------------------------------------------------------------
def signed_distances(scene: Scene, points: np.ndarray):
    """Signed distance (module docstring) and owning instance of every point.

    Returns ``(d, owner)``: (N,) float64 metres and (N,) int64 indices into
    :func:`mrcheck.eval.reference.triangle_owners`'s list.
    """
    import open3d as o3d

    from mrcheck.eval.reference import _raycasting_scene, triangle_owners

    # the scan's centre, not the scene's: one stray element far off (an IFC export's, at the
    # origin of a model at map coordinates) moves the scene's centre, and float32 there rounds
    # the CAD near the scan to metres
    origin = (points.min(axis=0) + points.max(axis=0)) / 2.0
    rc = _raycasting_scene(scene, origin)
    if rc is None:
        raise MrcheckError("the scene has no triangles to measure against", scene.source)
    _, first = triangle_owners(scene)
    d = np.empty(len(points), np.float64)
    owner = np.empty(len(points), np.int64)
    for start in range(0, len(points), QUERY_CHUNK):
        rel = points[start:start + QUERY_CHUNK] - origin          # float64, then float32 near 0
        result = rc.compute_closest_points(o3d.core.Tensor(rel.astype(np.float32)))
        offset = rel - result["points"].numpy().astype(np.float64)
        normal = result["primitive_normals"].numpy().astype(np.float64)
        # the closest triangle's normal gives the side, no watertightness needed; a point exactly
        # on the surface (dot 0) counts as outside
        sign = np.where(np.einsum("ij,ij->i", offset, normal) < 0.0, -1.0, 1.0)
        d[start:start + len(rel)] = sign * np.linalg.norm(offset, axis=1)
        ids = result["primitive_ids"].numpy().astype(np.int64)
        owner[start:start + len(rel)] = np.searchsorted(first, ids, side="right") - 1
    return d, owner


def part_statistics(scene: Scene, d: np.ndarray, owner: np.ndarray) -> list[dict]:
    """The ranked per-instance list (module docstring), metres."""
    from mrcheck.eval.reference import triangle_owners

    owners, _ = triangle_owners(scene)
    order = np.argsort(owner, kind="stable")
    bounds = np.searchsorted(owner[order], np.arange(len(owners) + 1))
    rows = []
    for i, (part, k) in enumerate(owners):
        mine = d[order[bounds[i]:bounds[i + 1]]]
        row = {"id": part.instance_ids[k], "part": part.name, "points": int(len(mine))}
        if len(mine):
            a = np.abs(mine)
            row.update(median_abs=float(np.median(a)), mean_abs=float(a.mean()),
                       p95_abs=float(np.percentile(a, 95)), signed_mean=float(mine.mean()),
                       signed_median=float(np.median(mine)))
        else:
            row.update(median_abs=None, mean_abs=None, p95_abs=None, signed_mean=None, signed_median=None)
        rows.append(row)
    # ranked by median |d|, largest first; instances without points last, in scene order
    rows.sort(key=lambda r: (r["points"] == 0, -(r["median_abs"] or 0.0)))
    for rank, row in enumerate(rows, 1):
        row["rank"] = rank
    return rows


# -- colours and images -------------------------------------------------------------------------------
def colour_scale_mm(d: np.ndarray) -> float:
    """S of the colour map in mm: the 95th percentile of |d| rounded up to 1, 2 or 5 x 10^k."""
    p95 = max(float(np.percentile(np.abs(d), 95)) * 1000.0, 1e-3)
    exponent = math.floor(math.log10(p95))
    for step in (1, 2, 5, 10):
        if step * 10.0 ** exponent >= p95 * (1 - 1e-9):
            return step * 10.0 ** exponent
    return 10.0 ** (exponent + 1)


def diverging_colours(d: np.ndarray, scale_m: float) -> np.ndarray:
    """(N, 3) uint8 RGB of signed distances, blue - white - red, saturating at +-scale_m."""
    x = np.clip(np.asarray(d, np.float64) / scale_m, -1.0, 1.0)
    stops = np.linspace(-1.0, 1.0, len(_RDBU))
    rgb = np.column_stack([np.interp(x, stops, _RDBU[:, c]) for c in range(3)])
    return np.rint(rgb).astype(np.uint8)


def splat(image: np.ndarray, uv: np.ndarray, depth: np.ndarray, colours: np.ndarray, radius: int = SPLAT_RADIUS):
    """Draw points as (2r+1)^2 squares into ``image`` in place, the nearest (smallest depth) on top."""
    h, w = image.shape[:2]
    u0, v0 = np.rint(uv[:, 0]).astype(np.int64), np.rint(uv[:, 1]).astype(np.int64)
    offsets = [(du, dv) for dv in range(-radius, radius + 1) for du in range(-radius, radius + 1)]
    pix, z, idx = [], [], []
    for du, dv in offsets:
        u, v = u0 + du, v0 + dv
        ok = (u >= 0) & (u < w) & (v >= 0) & (v < h)
        pix.append(v[ok] * w + u[ok])
        z.append(depth[ok])
        idx.append(np.nonzero(ok)[0])
    pix, z, idx = np.concatenate(pix), np.concatenate(z), np.concatenate(idx)
    if pix.size == 0:
        return image
    # a z-buffer without a loop: sort by pixel, then depth, and keep each pixel's first entry
    order = np.lexsort((z, pix))
    pix, idx = pix[order], idx[order]
    keep = np.ones(pix.size, bool)
    keep[1:] = pix[1:] != pix[:-1]
    image.reshape(-1, image.shape[2])[pix[keep]] = colours[idx[keep]]
    return image


def add_legend(image: np.ndarray, scale_mm: float, title: str = "signed distance (mm)") -> np.ndarray:
    """``image`` with a vertical colour bar and its mm scale on a panel to its right."""
    h = image.shape[0]
    width = max(130, h // 5)
    panel = np.full((h, width, 3), BACKGROUND, np.uint8)
    top, bottom = int(h * 0.12), int(h * 0.9)
    bar_x0, bar_x1 = int(width * 0.12), int(width * 0.28)
    values = np.linspace(1.0, -1.0, bottom - top) * scale_mm / 1000.0       # + at the top
    panel[top:bottom, bar_x0:bar_x1] = diverging_colours(values, scale_mm / 1000.0)[:, None, :]
    font_scale = max(0.35, h / 1400.0)
    thickness = max(1, int(round(font_scale * 1.6)))
    cv2.putText(panel, title, (4, int(h * 0.06)), cv2.FONT_HERSHEY_SIMPLEX, font_scale * 0.8, (240, 240, 240),
                thickness, cv2.LINE_AA)
    for fraction in (1.0, 0.5, 0.0, -0.5, -1.0):
        y = int(round(top + (1.0 - fraction) / 2.0 * (bottom - top - 1)))
        value = fraction * scale_mm
        label = f"{value:+g}" if fraction else "0"
        if abs(fraction) == 1.0:
            label = (">= " if fraction > 0 else "<= ") + label   # the map saturates there
        cv2.line(panel, (bar_x1, y), (bar_x1 + 6, y), (240, 240, 240), 1)
        cv2.putText(panel, label, (bar_x1 + 9, y + int(5 * font_scale / 0.5)), cv2.FONT_HERSHEY_SIMPLEX, font_scale,
                    (240, 240, 240), thickness, cv2.LINE_AA)
    return np.hstack([image, panel])


def orthographic_image(points: np.ndarray, colours: np.ndarray, view: str, size: int = IMAGE_SIZE) -> np.ndarray:
    """A splat image of the scan seen from above (``"top"``: x right, y up, highest on top) or
    from the front (``"side"``: x right, z up, looking along +y, smallest y on top)."""
    across, up, toward = (0, 1, 2) if view == "top" else (0, 2, 1)
    lo, hi = points.min(axis=0), points.max(axis=0)
    extent = max(hi[across] - lo[across], hi[up] - lo[up], 1e-9)
    pixel = extent / (size - 8)
    w = int(math.ceil((hi[across] - lo[across]) / pixel)) + 8
    h = int(math.ceil((hi[up] - lo[up]) / pixel)) + 8
    uv = np.column_stack(((points[:, across] - lo[across]) / pixel + 4, (hi[up] - points[:, up]) / pixel + 4))
    depth = -points[:, toward] if view == "top" else points[:, toward]
    image = np.full((max(h, 64), w, 3), BACKGROUND, np.uint8)
    return splat(image, uv, depth, colours)


def project_to_shot(points: np.ndarray, camera):
    """Pixel positions (with lens distortion) and depths of the points in front of ``camera``."""
    cam = points @ camera.R.T + camera.t                     # float64 throughout
    front = cam[:, 2] > 1e-6
    cam = cam[front]
    x, y = cam[:, 0] / cam[:, 2], cam[:, 1] / cam[:, 2]
    # keep the points within 1.5 image of the pinhole frame: a polynomial lens model folds back
    # far outside the field of view and would scatter them over the photo
    margin_x, margin_y = 0.75 * camera.width / camera.fx, 0.75 * camera.height / camera.fy
    cx, cy = (camera.cx - camera.width / 2) / camera.fx, (camera.cy - camera.height / 2) / camera.fy
    near = (np.abs(x + cx) < margin_x) & (np.abs(y + cy) < margin_y)
    cam = cam[near]
    uv, _ = cv2.projectPoints(cam.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), camera.K, camera.dist)
    index = np.nonzero(front)[0][near]
    return uv.reshape(-1, 2), cam[:, 2], index


def shot_images(scene: Scene, camera, photo, points, colours, scale_mm) -> dict:
    """The scan splatted over the shot's CAD render and over the photo + CAD overlay."""
    from mrcheck.mr.overlay import overlay_images
    from mrcheck.mr.shot import render_for_photo
    from mrcheck.render.renderer import Renderer, RenderSettings

    renderer = Renderer(scene)
    try:
        renders, _, offset, maps = render_for_photo(renderer, camera, ["phong"], RenderSettings(), False)
    finally:
        renderer.release()
    uv, depth, index = project_to_shot(points, camera)
    out = {}
    for name, alpha in SHOT_IMAGES.items():
        base = overlay_images(photo, renders, camera, alpha, None, offset=offset, maps=maps)["phong"]
        out[name] = add_legend(splat(base.copy(), uv, depth, colours[index]), scale_mm)
    return out


# -- reports -----------------------------------------------------------------------------------------
def _mm(value) -> str:
    return "-" if value is None else f"{value * 1000.0:.2f}"


def parts_markdown(report: dict) -> str:
    lines = [f"# Deviation of {report['scan']} from {report['scene']}", "",
             f"{report['points']} scan points; median |d| {_mm(report['median_abs'])} mm, "
             f"95th percentile {_mm(report['p95_abs'])} mm. Signed: > 0 in front of the CAD surface "
             "(along the closest triangle's normal), < 0 behind it.", "",
             "| rank | instance | part | points | median abs (mm) | mean abs (mm) | p95 abs (mm) | signed mean (mm) |",
             "|---:|---|---|---:|---:|---:|---:|---:|"]
    for r in report["parts"]:
        lines.append(f"| {r['rank']} | {r['id']} | {r['part']} | {r['points']} | {_mm(r['median_abs'])} | "
                     f"{_mm(r['mean_abs'])} | {_mm(r['p95_abs'])} | {_mm(r['signed_mean'])} |")
    return "\n".join(lines) + "\n"


def _npy_bytes(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


# -- the command --------------------------------------------------------------------------------------
def deviation(points: np.ndarray, scene: Scene, scan=None):
    """Check scan points (metres, :func:`read_scan`) against a loaded scene and measure them;
    returns ``(d, owner, parts)``. ``scan`` names the file in errors."""
    scan_diag, scene_diag = check_placement(points, scene, scan)
    d, owner = signed_distances(scene, points)
    size = max(scan_diag, FAR_SCENE_SHARE * scene_diag, FAR_FLOOR_M)
    median = float(np.median(np.abs(d)))
    # a scan in the scene's box but nowhere on its surfaces: as a hall-sized scan of the wrong cell
    if median > FAR_FACTOR * size:
        _far(median, scan)
    return d, owner, part_statistics(scene, d, owner)


def deviation_command(scan, scene, shot=None, units=None, outdir="deviation"):
    """``mrcheck deviation``: check everything, compute, then write every output atomically."""
    from mrcheck.core.camerafiles import load_shot, read_photo
    from mrcheck.scene.model import load_scene

    outdir = check_output_dir(outdir)
    camera = photo = photo_path = None
    if shot is not None:
        camera, photo_path = load_shot(shot)
    names = [DEVIATIONS, PARTS_JSON, PARTS_MD, *VIEW_IMAGES.values(), *(SHOT_IMAGES if shot is not None else ())]
    check_not_inputs([outdir / name for name in names], [("the scan", scan), ("--shot", shot),
                                                         ("the shot's photo", photo_path), ("the scene", scene_files(scene))])
    if shot is not None:
        photo = read_photo(photo_path, camera)
    points = read_scan(scan, units)          # the scan's own errors before the slow scene load
    loaded = load_scene(scene, progress=True)
    d, owner, parts = deviation(points, loaded, scan)

    scale_mm = colour_scale_mm(d)
    colours = diverging_colours(d, scale_mm / 1000.0)
    images = {name: add_legend(orthographic_image(points, colours, view), scale_mm) for view, name in VIEW_IMAGES.items()}
    if camera is not None:
        images.update(shot_images(loaded, camera, photo, points, colours, scale_mm))
    a = np.abs(d)
    report = {"scan": str(scan), "scene": str(scene), "units": units or "m", "points": int(len(d)),
              "median_abs": float(np.median(a)), "mean_abs": float(a.mean()), "p95_abs": float(np.percentile(a, 95)),
              "signed_mean": float(d.mean()), "distance_unit": "m",
              "sign": "sign of (point - closest point) . closest triangle normal; > 0 in front of the CAD surface",
              "colour_scale_mm": scale_mm, "parts": parts}

    # all or none: a deviations.npy without its parts.json would pass for a complete result
    write_all_or_none([lambda: write_bytes(outdir / DEVIATIONS, _npy_bytes(d.astype(np.float32))),
                       lambda: write_text(outdir / PARTS_JSON, json.dumps(report, indent=2) + "\n"),
                       lambda: write_text(outdir / PARTS_MD, parts_markdown(report)),
                       *(lambda name=name, image=image: write_image(outdir / name, image) for name, image in images.items())])
    print(outdir)
    print(f"deviation: {len(d)} points, median |d| {report['median_abs'] * 1000:.3f} mm, "
          f"p95 {report['p95_abs'] * 1000:.3f} mm; top: {parts[0]['id']}", file=sys.stderr)
    return report


__all__ = [
    "deviation_command", "deviation", "read_scan", "check_placement", "signed_distances", "part_statistics",
    "colour_scale_mm", "diverging_colours", "splat", "add_legend", "orthographic_image", "project_to_shot",
    "shot_images", "parts_markdown", "SCAN_SUFFIXES",
]
