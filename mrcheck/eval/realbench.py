"""``mrcheck bench --real``: markerless registration and ``track`` on the shared real data.

The data (``../shared/data/real/``, read in place, never copied: see its README for sources and
licences) and the protocol:

* **Held-out split, fixed before any tuning.** LM-O has three photos (``test/000002/rgb``):
  000003 and 000402 are the photos a method may be tuned on; **000819 is held out** (all its
  objects) and reported separately everywhere. M3T has two frames but only frame 200 has a
  published pose (frame 201 has none), so it has no held-out frame: its held-out part is the
  starts of :data:`M3T_HELD_OUT_SEEDS`.
* **LM-O**: each annotated object in turn is the anchor: the scene is the photo's 8 objects as
  parts, world = the anchor's model frame, the others placed by their ground-truth poses; the
  camera pose is what is registered. Starts: the truth, and the truth moved in a random
  direction (rotation and translation mixed, :func:`mrcheck.eval.edgephotos.perturbed`) by
  10, 20 and 40 px median reprojection of the anchor's vertices, :data:`SEEDS` seeds each.
  From every start both mrcheck's snap (:func:`mrcheck.mr.edges.refine_pose`, what
  ``register --initial`` runs) and ``cv2.rapid`` (:func:`mrcheck.eval.edgebench.rapid_refine`)
  run. Recorded per fit: the anchor's rotation (degrees) and translation (cm) error, the median
  reprojection error of its vertices (px), refused or not (the reason), seconds. Success:
  5 deg / 5 cm (BOP's 5cm5deg, RBOT) and, separately, <= 2 px; from the truth: <= 1 px.
  A refused fit counts as a failure (its pose is not the truth).
* **M3T frame 200**: the two bodies in the camera frame, from the published pose and from
  20 px off (:data:`M3T_SEEDS` seeds); error vs the published pose (px, all vertices; and at
  the worse of the two bodies). Frame 201 has no pose, so the held-out part is starts, not a
  frame: seeds :data:`M3T_HELD_OUT_SEEDS`, reported as split "held-out".
* **Videos** (:mod:`mrcheck.eval.realvideo`): ``track`` from a start solved from corners
  marked by eye on frame 0 (``tests/data/*_clicks.json``).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass, field

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import read_photo
from mrcheck.core.errors import MrcheckError
from mrcheck.core.output import check_output_path, write_text
from mrcheck.eval.edgebench import rapid_refine
from mrcheck.eval.edgephotos import perturbed, reprojection_error
from mrcheck.eval.realdata import anchored_scene, camera_scene, lmo_photo, m3t_photo, real_root
from mrcheck.mr.edges import EdgeFitError, EdgeOptions, refine_pose, scene_edges

LMO_TUNED = (3, 402)
LMO_HELD_OUT = (819,)
OFFSETS_PX = (10.0, 20.0, 40.0)
SEEDS = 2
M3T_SEEDS = 10  # M3T's only frame with a pose: more starts instead of another frame
# starts held out instead of a frame: never run while the per-part restarts were tuned (on seeds
# 0-9; seeds 20-29 were looked at once during that work)
M3T_HELD_OUT_SEEDS = range(40, 50)
SUCCESS_DEG, SUCCESS_CM, SUCCESS_PX, TRUTH_PX = 5.0, 5.0, 2.0, 1.0
METHODS = ("mrcheck", "cv2.rapid")
MAX_POINTS = 3000
_OBJECT_POINTS = 500  # per object, for RealFit.farthest_px


@dataclass
class RealFit:
    """One method from one start: ``split`` "tuned" or "held-out"; ``offset_px`` 0 for the
    truth start; errors None when refused (``note`` the reason); ``farthest_px``: the start's
    offset (median px) at the scene's object it puts farthest off (an LM-O start is
    ``offset_px`` off at the anchor only: a turn about a small anchor moves the rest more);
    ``worst_px``: the same for the fitted pose (M3T's error over all vertices is mostly the
    bottle's: a prism 12 px off hides in it); ``part_above``: mrcheck's support beyond chance
    per part (:attr:`~mrcheck.mr.edges.EdgeFit.part_above`); ``note`` of a fit not refused: its
    restart (:attr:`~mrcheck.mr.edges.EdgeFit.restart`), if any."""

    dataset: str
    photo: str
    split: str
    anchor: str
    method: str
    seed: int
    offset_px: float
    start_px: float
    error_px: float | None
    rot_deg: float | None
    trans_cm: float | None
    refused: bool
    seconds: float
    note: str = ""
    farthest_px: float | None = None
    worst_px: float | None = None
    part_above: dict = field(default_factory=dict)

    @property
    def ok_5deg5cm(self) -> bool:
        if self.rot_deg is None or self.trans_cm is None:
            return False
        return self.rot_deg <= SUCCESS_DEG and self.trans_cm <= SUCCESS_CM

    @property
    def ok_px(self) -> bool:
        limit = TRUTH_PX if self.offset_px == 0 else SUCCESS_PX
        return self.error_px is not None and self.error_px <= limit


@dataclass
class RealBench:
    """Every fit, the video runs and what was skipped (with why)."""

    fits: list = field(default_factory=list)
    videos: list = field(default_factory=list)
    skipped: list = field(default_factory=list)


def lmo_splits(items) -> list[tuple[str, list]]:
    """``items`` (each with an LM-O ``photo`` number) as ``[("tuned", ...), ("held-out", ...)]``,
    the held-out photos (:data:`LMO_HELD_OUT`) apart; a split without items is left out."""
    splits = [("tuned", [i for i in items if i.photo not in LMO_HELD_OUT])]
    splits.append(("held-out", [i for i in items if i.photo in LMO_HELD_OUT]))
    return [(name, mine) for name, mine in splits if mine]


def pose_errors(truth: Camera, estimate: Camera) -> tuple[float, float]:
    """Rotation (degrees) and translation (cm) error of the world-to-camera pose (the anchor's
    model-to-camera pose when world = its model frame), as BOP's 5cm5deg."""
    # the rotation vector's length, not acos of the trace: exact near zero as well
    angle = float(np.linalg.norm(cv2.Rodrigues(estimate.R @ truth.R.T)[0]))
    return math.degrees(angle), 100.0 * float(np.linalg.norm(estimate.t - truth.t))


def _run(method, scene, truth, rgb, start, edges, offset):
    """(camera or None, seconds, note, per-part support beyond chance) of one method from
    ``start`` on the photo ``rgb``: in colour for mrcheck, as ``register`` reads it (the
    outline's region criterion compares colours), grey for ``cv2.rapid``."""
    began = time.perf_counter()
    try:
        if method == "mrcheck":
            fit = refine_pose(scene, truth, rgb, initial=start, edges=edges)
            return fit.camera, time.perf_counter() - began, fit.restart, fit.part_above
        grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
        camera = rapid_refine(scene, truth, grey, start, max(1.5 * offset, 3.0))
        return camera, time.perf_counter() - began, "", {}
    except EdgeFitError as exc:
        return None, time.perf_counter() - began, str(exc), {}
    except (cv2.error, MrcheckError) as exc:
        return None, time.perf_counter() - began, str(exc).splitlines()[0][:160], {}


def fit_starts(
    label: dict, scene, truth: Camera, rgb, points, offsets, seeds, objects=(), from_truth: bool = True
) -> list[RealFit]:
    """Both methods from the truth (``from_truth``) and from every (offset, seed) start (``seeds``:
    the seed numbers); ``label``: the :class:`RealFit` fields naming the case (dataset, photo,
    split, anchor); ``objects``: each object's world points, for :attr:`RealFit.farthest_px` and
    :attr:`RealFit.worst_px`."""
    edges = scene_edges(scene)
    starts = [(0.0, 0, truth)] if from_truth else []
    for offset in offsets:
        for seed in seeds:
            rng = np.random.default_rng(1000 * seed + int(offset))
            starts.append((offset, seed, perturbed(truth, points, offset, rng)))
    rows = []
    for offset, seed, start in starts:
        start_px = float(np.median(reprojection_error(truth, start, points)))
        farthest = _worst(truth, start, objects)
        for method in METHODS:
            camera, seconds, note, parts = _run(method, scene, truth, rgb, start, edges, offset)
            case = {**label, "method": method, "seed": seed, "offset_px": offset, "start_px": start_px,
                    "farthest_px": farthest}  # fmt: skip
            if camera is None:
                rows.append(RealFit(**case, error_px=None, rot_deg=None, trans_cm=None, refused=True,
                                    seconds=seconds, note=note))  # fmt: skip
                continue
            rot, trans = pose_errors(truth, camera)
            error = float(np.median(reprojection_error(truth, camera, points)))
            rows.append(RealFit(**case, error_px=error, rot_deg=rot, trans_cm=trans, refused=False, seconds=seconds,
                                note=note, worst_px=_worst(truth, camera, objects), part_above=parts))  # fmt: skip
    return rows


def _worst(truth: Camera, camera: Camera, objects) -> float | None:
    """The largest of the objects' median reprojection errors of ``camera`` against ``truth``."""
    return max((float(np.median(reprojection_error(truth, camera, p))) for p in objects), default=None)


def _sample(points: np.ndarray, seed: int = 0, most: int = MAX_POINTS) -> np.ndarray:
    if len(points) <= most:
        return points
    return points[np.random.default_rng(seed).choice(len(points), most, replace=False)]


def placed(vertices: np.ndarray, pose: np.ndarray, most: int = _OBJECT_POINTS) -> np.ndarray:
    """Up to ``most`` of an object's ``vertices`` moved by the 4x4 ``pose``."""
    return _sample(vertices, most=most) @ pose[:3, :3].T + pose[:3, 3]


def lmo_fits(root, quick: bool, progress=None) -> list[RealFit]:
    """The LM-O cases of the module docstring (``quick``: the first two anchors of one tuned
    photo and of the held-out photo, 20 px only, one seed)."""
    images = (LMO_TUNED[0], LMO_HELD_OUT[0]) if quick else LMO_TUNED + LMO_HELD_OUT
    offsets, seeds = ((20.0,), 1) if quick else (OFFSETS_PX, SEEDS)
    meshes: dict = {}
    rows = []
    for image in images:
        photo = lmo_photo(root, image, meshes)
        rgb = read_photo(photo.photo)
        split = "held-out" if image in LMO_HELD_OUT else "tuned"
        for anchor, obj in enumerate(photo.objects[:2] if quick else photo.objects):
            scene, truth = anchored_scene(photo, anchor)
            label = {"dataset": "lmo", "photo": photo.name, "split": split, "anchor": obj.name}
            inv = np.linalg.inv(obj.pose)
            objects = [placed(o.vertices, inv @ o.pose) for o in photo.objects]
            rows += fit_starts(label, scene, truth, rgb, _sample(obj.vertices), offsets, range(seeds), objects)
            if progress:
                progress(f"{photo.name} anchor {obj.name}: {len(rows)} fits")
    return rows


def m3t_fits(root, quick: bool, progress=None) -> list[RealFit]:
    """M3T frame 200 from the published pose and from 20 px off (:data:`M3T_SEEDS` starts), and
    (not ``quick``) from the held-out starts :data:`M3T_HELD_OUT_SEEDS`."""
    photo = m3t_photo(root, 200)
    scene, truth = camera_scene(photo)
    rgb = read_photo(photo.photo)
    points = np.concatenate([placed(o.vertices, o.pose, MAX_POINTS) for o in photo.objects])
    objects = [placed(o.vertices, o.pose) for o in photo.objects]
    label = {"dataset": "m3t", "photo": photo.name, "split": "tuned", "anchor": "camera"}
    rows = fit_starts(label, scene, truth, rgb, points, (20.0,), range(1 if quick else M3T_SEEDS), objects)
    if not quick:
        held = {**label, "split": "held-out"}
        rows += fit_starts(held, scene, truth, rgb, points, (20.0,), M3T_HELD_OUT_SEEDS, objects, from_truth=False)
    if progress:
        progress(f"{photo.name}: {len(rows)} fits")
    return rows


def real_bench(quick: bool = False, json_path=None, videos: bool = True, progress=None, root=None) -> RealBench:
    """Everything of the module docstring whose data is present (else skipped, with why);
    ``json_path``: the records written there (checked before the work)."""
    from mrcheck.eval.realvideo import video_runs

    if json_path is not None:
        json_path = check_output_path(json_path, (".json",), "JSON output")
    root = real_root() if root is None else root
    bench = RealBench()
    for name, folder, run in (("LM-O", "lmo", lmo_fits), ("M3T", "m3t", m3t_fits)):
        if (root / folder).is_dir():
            bench.fits += run(root, quick, progress)
        else:
            bench.skipped.append(f"{name}: {root / folder} is absent")
    if videos:
        bench.videos, skipped = video_runs(root, quick, progress)
        bench.skipped += skipped
    if json_path is not None:
        write_text(json_path, json.dumps(bench_json(bench, quick), indent=2))
    return bench


def bench_json(bench: RealBench, quick: bool) -> dict:
    fits = [dict(asdict(f), ok_5deg5cm=f.ok_5deg5cm, ok_px=f.ok_px) for f in bench.fits]
    return {
        "quick": quick,
        "held_out": {
            "lmo": [f"lmo-{i:06d}" for i in LMO_HELD_OUT],
            "m3t": [f"m3t-000200 seed {s}" for s in M3T_HELD_OUT_SEEDS],
        },
        "criteria": {"deg": SUCCESS_DEG, "cm": SUCCESS_CM, "px": SUCCESS_PX, "truth_px": TRUTH_PX},
        "fits": fits,
        "videos": [asdict(v) for v in bench.videos],
        "skipped": bench.skipped,
    }


def _pct(values) -> str:
    finite = [v for v in values if v is not None]
    if not finite:
        return "-"
    q = np.percentile(finite, [50, 90, 100])
    return f"{q[0]:.1f}/{q[1]:.1f}/{q[2]:.1f}"


def fit_lines(fits: list) -> list[str]:
    """Per data set, split, start offset and method: fits, refused, 5deg/5cm successes, px
    successes (<= 2 px; <= 1 px from the truth), the error quantiles of the fits not refused
    (median/90 %/max, px, degrees and px at the worst-fitted object) and the median seconds."""
    head = f"{'set':<5} {'split':<8} {'start':>6} {'method':<9} {'fits':>4} {'refused':>7} {'5deg5cm':>7} "
    lines = [head + f"{'<=px':>5} {'px med/90%/max':>18} {'deg med/90%/max':>18} {'worst obj px':>18} {'s':>5}"]
    groups: dict = {}
    for f in fits:
        groups.setdefault((f.dataset, f.split, f.offset_px, f.method), []).append(f)
    for (dataset, split, offset, method), mine in sorted(groups.items(), key=lambda kv: kv[0]):
        start = "truth" if offset == 0 else f"{offset:g}px"
        lines.append(
            f"{dataset:<5} {split:<8} {start:>6} {method:<9} {len(mine):4d} {sum(f.refused for f in mine):7d} "
            f"{sum(f.ok_5deg5cm for f in mine):7d} {sum(f.ok_px for f in mine):5d} "
            f"{_pct([f.error_px for f in mine]):>18} {_pct([f.rot_deg for f in mine]):>18} "
            f"{_pct([f.worst_px for f in mine]):>18} {np.median([f.seconds for f in mine]):5.2f}"
        )
    return lines


def reason_lines(fits: list, most: int = 6) -> list[str]:
    """The commonest refusal reasons per method (numbers masked so that alike reasons group)."""
    import re

    lines = []
    for method in METHODS:
        counts: dict = {}
        for f in fits:
            if f.method == method and f.refused:
                key = re.sub(r"[0-9.]+", "N", f.note)[:110]
                counts[key] = counts.get(key, 0) + 1
        for reason, count in sorted(counts.items(), key=lambda kv: -kv[1])[:most]:
            lines.append(f"  {method} refused {count}x: {reason}")
    return lines


def reach_lines(fits: list, radius: float) -> list[str]:
    """Per LM-O split, mrcheck's starts off the truth: how many put some object of the scene beyond
    the snap's search ``radius`` (:attr:`RealFit.farthest_px`), and the refusals among those
    and among the others."""
    lines = []
    for split in ("tuned", "held-out"):
        mine = [
            f for f in fits if f.dataset == "lmo" and f.split == split and f.method == "mrcheck" and f.offset_px > 0
        ]
        if not mine:
            continue
        beyond = [f for f in mine if f.farthest_px is not None and f.farthest_px > radius]
        within = [f for f in mine if f not in beyond]
        lines.append(
            f"  mrcheck, {split}: {len(beyond)} of {len(mine)} starts put an object beyond the {radius:g} px "
            f"search radius (refused {sum(f.refused for f in beyond)}, succeeded "
            f"{sum(f.ok_5deg5cm and f.ok_px for f in beyond)}); the other {len(within)}: refused "
            f"{sum(f.refused for f in within)}, succeeded {sum(f.ok_5deg5cm and f.ok_px for f in within)}"
        )
    return lines


def restart_lines(fits: list) -> list[str]:
    """Per data set and split, mrcheck's fits that were made again because one part lagged
    (:mod:`mrcheck.mr.edges.restarts`), and how many kept a restart."""
    lines = []
    for dataset in ("lmo", "m3t"):
        for split in ("tuned", "held-out"):
            mine = [f for f in fits if (f.dataset, f.split, f.method) == (dataset, split, "mrcheck") and not f.refused]
            restarted = [f for f in mine if "restarts along" in f.note]
            if mine:
                kept = sum("kept a restart" in f.note for f in restarted)
                lines.append(
                    f"  mrcheck, {dataset} {split}: {len(restarted)} of {len(mine)} fits restarted (a part "
                    f"lagging), {kept} kept a restart"
                )
    return lines


def video_lines(videos: list) -> list[str]:
    lines = [
        f"{'video':<24} {'frames':>6} {'lost':>4} {'held':>4} {'outline px med/90%/max':>22} {'fps':>5} "
        f"{'clicks px':>9}"
    ]
    for v in videos:
        if v.error:
            lines.append(f"{v.video:<24} track failed: {v.error} (clicks RMS {v.click_rms_px:.2f} px)")
            continue
        finite = [d for d in v.outline_px if np.isfinite(d)]
        lines.append(
            f"{v.video:<24} {v.frames:6d} {v.lost:4d} {v.held:4d} {_pct(finite):>22} {v.fps:5.2f} {v.click_rms_px:9.2f}"
        )
    return lines


def summary_lines(bench: RealBench) -> list[str]:
    """The printed table: the fits (held-out rows apart by their split column), the refusal
    reasons, the videos and what was skipped."""
    lines = [
        f"== mrcheck bench --real: registration (success {SUCCESS_DEG:g} deg / {SUCCESS_CM:g} cm; px: <= "
        f"{SUCCESS_PX:g} px, from the truth <= {TRUTH_PX:g} px; held out: "
        + ", ".join(f"lmo-{i:06d}" for i in LMO_HELD_OUT)
        + ") ==",
        *fit_lines(bench.fits),
        *reason_lines(bench.fits),
        *reach_lines(bench.fits, EdgeOptions().search_px),
        *restart_lines(bench.fits),
    ]
    if bench.videos:
        lines += [
            "== mrcheck track on real videos (held: not lost and outline <= 3 px) ==",
            *video_lines(bench.videos),
        ]
    lines += [f"skipped: {reason}" for reason in bench.skipped]
    return lines


__all__ = [
    "summary_lines",
    "reach_lines",
    "restart_lines",
    "RealFit",
    "RealBench",
    "pose_errors",
    "lmo_splits",
    "fit_starts",
    "lmo_fits",
    "m3t_fits",
    "real_bench",
    "bench_json",
    "LMO_TUNED",
    "LMO_HELD_OUT",
    "OFFSETS_PX",
    "SEEDS",
    "M3T_HELD_OUT_SEEDS",
    "MAX_POINTS",
    "placed",
    "METHODS",
]
