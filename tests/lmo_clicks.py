"""Simulated clicks on BOP LM-O's real photos (``../shared/data/real/lmo``): ``--points`` and
``--points --refine`` against the ground truth. Run from the repository's root::

    PYTHONPATH=$PWD python tests/lmo_clicks.py [--refine] [--photos 3,402] [--seeds 0-4]

For every photo and annotated object (the anchor: the world is its model frame, metres), 8 clicks
on its visible vertices (facing the camera, inside BOP's visible box, spread by farthest-point
sampling), projected with the ground truth plus 1.5 px Gaussian noise per axis, seeds 0-4;
"miss" cases move one click 10-30 px. Each case: rotation (deg) and translation (mm) error, the
median reprojection error of the model's vertices (px), honest clicks rejected, refusals.
Photo 819 is held out: tune on 3 and 402 only, report 819 separately.
"""

from __future__ import annotations

import argparse
import inspect
import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError
from mrcheck.eval.realdata import LMO_NAMES, real_root
from mrcheck.mr.registration import register_points

LMO = real_root() / "lmo"
SCENE = LMO / "test" / "000002"
TUNE_PHOTOS = (3, 402)
HELD_OUT = 819
CLICKS = 8
NOISE_PX = 1.5


@dataclass(frozen=True)
class Case:
    photo: int
    obj: int
    seed: int
    miss: bool  # one gross mis-click of 10-30 px


@dataclass(frozen=True)
class Outcome:
    case: Case
    refused: str | None  # the error, when refused
    rot_deg: float = math.nan
    trans_mm: float = math.nan
    median_px: float = math.nan
    honest_rejected: int = 0
    miss_rejected: bool = False
    refine: Outcome | None = None  # the --refine result, with refused = the reason it was not applied


def read_ply(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and vertex normals (mm) of BOP's ASCII PLY."""
    with path.open() as f:
        count = 0
        for line in f:
            if line.startswith("element vertex"):
                count = int(line.split()[2])
            if line.strip() == "end_header":
                break
        data = np.loadtxt(f, max_rows=count, usecols=range(6))
    return data[:, :3], data[:, 3:6]


def nearest_rotation(R: np.ndarray) -> np.ndarray:
    """LM-O's rotations are orthonormal only to 1e-2 (its README): the closest rotation (SVD)."""
    u, _, vt = np.linalg.svd(R)
    return u @ np.diag([1, 1, np.linalg.det(u @ vt)]) @ vt


def camera_k() -> Camera:
    c = json.loads((LMO / "camera.json").read_text())
    K = np.array([[c["fx"], 0, c["cx"]], [0, c["fy"], c["cy"]], [0, 0, 1]])
    return Camera(c["width"], c["height"], K)


def ground_truth(photo: int) -> dict[int, tuple[np.ndarray, np.ndarray, list[int]]]:
    """Per object: R, t (m), BOP's visible box [x, y, w, h]."""
    gt = json.loads((SCENE / "scene_gt.json").read_text())[str(photo)]
    info = json.loads((SCENE / "scene_gt_info.json").read_text())[str(photo)]
    out = {}
    for g, i in zip(gt, info):
        R = nearest_rotation(np.array(g["cam_R_m2c"], float).reshape(3, 3))
        out[g["obj_id"]] = (R, np.array(g["cam_t_m2c"], float) / 1000.0, i["bbox_visib"])
    return out


def click_targets(camera: Camera, vertices: np.ndarray, normals: np.ndarray, box: list[int]) -> np.ndarray:
    """8 visible vertices (m) spread over the object: farthest-point sampling from the one
    nearest the visible box's centre."""
    x, y, w, h = box
    cam = vertices @ camera.R.T + camera.t
    uv = camera.project(vertices)
    facing = np.einsum("ij,ij->i", normals @ camera.R.T, cam) < 0
    inside = (uv[:, 0] >= x) & (uv[:, 0] < x + w) & (uv[:, 1] >= y) & (uv[:, 1] < y + h)
    pool = vertices[facing & inside]
    chosen = [int(np.argmin(np.linalg.norm(camera.project(pool) - (x + w / 2, y + h / 2), axis=1)))]
    distance = np.linalg.norm(pool - pool[chosen[0]], axis=1)
    for _ in range(CLICKS - 1):
        chosen.append(int(np.argmax(distance)))
        distance = np.minimum(distance, np.linalg.norm(pool - pool[chosen[-1]], axis=1))
    return pool[chosen]


def _errors(found: Camera, truth: Camera, vertices: np.ndarray) -> tuple[float, float, float]:
    cos = (np.trace(found.R @ truth.R.T) - 1) / 2
    rot = math.degrees(math.acos(min(1.0, max(-1.0, cos))))
    median = float(np.median(np.linalg.norm(found.project(vertices) - truth.project(vertices), axis=1)))
    return rot, float(np.linalg.norm(found.t - truth.t) * 1000), median


def run_case(case: Case, truth: Camera, vertices: np.ndarray, targets: np.ndarray, refine=None) -> Outcome:
    rng = np.random.default_rng(case.seed)
    pixels = truth.project(targets) + rng.normal(0.0, NOISE_PX, size=(len(targets), 2))
    missed = -1
    if case.miss:
        missed = int(rng.integers(len(targets)))
        angle = rng.uniform(0, 2 * math.pi)
        pixels[missed] += rng.uniform(10, 30) * np.array([math.cos(angle), math.sin(angle)])
    pairs = {"points": [{"pixel": p.tolist(), "world": w.tolist()} for p, w in zip(pixels, targets)]}
    intrinsics = Camera(truth.width, truth.height, truth.K)
    kwargs = {"click_sigma": NOISE_PX} if "click_sigma" in inspect.signature(register_points).parameters else {}
    try:
        shot = register_points(intrinsics, pairs, **kwargs)
    except MrcheckError as exc:
        return Outcome(case, str(exc))
    rejected = [r["index"] for r in shot.report["rejected"]]
    rot, trans, median = _errors(shot.camera, truth, vertices)
    refined = refine(shot) if refine else None
    if refined is not None:
        reason, camera = refined
        refined = Outcome(case, reason) if camera is None else Outcome(case, reason, *_errors(camera, truth, vertices))
    return Outcome(case, None, rot, trans, median, sum(i != missed for i in rejected), missed in rejected, refined)


def refiner(photo: int, obj: int):
    """``--points --refine`` on the whole desk (the photo's annotated objects, world = the
    anchor's model frame: the plan a planner would have, other objects hiding parts of the
    anchor's outline): (reason not applied or None, camera)."""
    from mrcheck.eval.realdata import anchored_scene, lmo_photo
    from mrcheck.mr.register import gated_refinement

    desk = lmo_photo(LMO.parent, photo)
    model = anchored_scene(desk, [o.name for o in desk.objects].index(LMO_NAMES[obj]))[0]
    image = SCENE / "rgb" / f"{photo:06d}.png"

    def refine(shot):
        done = gated_refinement(shot, image, shot.camera, model, "points")
        return done.report.get("refinement"), done.camera

    return refine


def run(photos, seeds, with_refine: bool) -> list[Outcome]:
    camera = camera_k()
    out = []
    for photo in photos:
        for obj, (R, t, box) in sorted(ground_truth(photo).items()):
            vertices, normals = read_ply(LMO / "models" / f"obj_{obj:06d}.ply")
            vertices, normals = vertices / 1000.0, normals
            truth = camera.with_pose(R, t)
            targets = click_targets(truth, vertices, normals, box)
            refine = refiner(photo, obj) if with_refine else None
            for seed in seeds:
                for miss in (False, True):
                    out.append(run_case(Case(photo, obj, seed, miss), truth, vertices, targets, refine))
    return out


def summary(outcomes: list[Outcome]) -> str:
    done = [o for o in outcomes if o.refused is None]
    ambiguous = sum("ambiguous" in (o.refused or "") for o in outcomes)
    rot = np.array([o.rot_deg for o in done])
    med = np.array([o.median_px for o in done])
    trans = np.array([o.trans_mm for o in done])
    honest = sum(o.honest_rejected for o in done)
    clicks = sum(CLICKS - o.case.miss for o in done)
    misses = [o for o in done if o.case.miss]
    lines = [
        f"cases {len(outcomes)}, refused {len(outcomes) - len(done)} (ambiguous {ambiguous}); "
        f"honest clicks rejected {honest} of {clicks}; mis-clicks rejected {sum(o.miss_rejected for o in misses)} "
        f"of {len(misses)}",
        f"  rotation deg median {np.median(rot):.2f} p90 {np.percentile(rot, 90):.2f} max {rot.max():.2f}; "
        f"translation mm median {np.median(trans):.1f} max {trans.max():.1f}; "
        f"reprojection px median {np.median(med):.2f} p90 {np.percentile(med, 90):.2f} max {med.max():.2f}; "
        f"within 5 deg / 5 cm {np.mean((rot <= 5) & (trans <= 50)):.0%}",
    ]
    refined = [(o, o.refine) for o in done if o.refine is not None]
    if refined:
        kept = [r for _, r in refined if r.refused is not None]
        failed = sum(math.isnan(r.median_px) for _, r in refined)
        worse = [(o, r) for o, r in refined if r.median_px > o.median_px + 1e-9]
        worse_rot = [(o, r) for o, r in refined if r.rot_deg > o.rot_deg + 0.5]
        much = [(o, r) for o, r in worse if r.median_px > o.median_px + 1.0]
        final = np.array([o.median_px if r.refused else r.median_px for o, r in refined])
        lines.append(
            f"  refine: applied {len(refined) - len(kept)}, not applied {len(kept)}, refused (no pose) {failed}; "
            f"worse than points: median px {len(worse)} (by > 1 px {len(much)}), rotation by > 0.5 deg "
            f"{len(worse_rot)}; reprojection px median {np.median(final):.2f} p90 {np.percentile(final, 90):.2f} "
            f"max {final.max():.2f}"
        )
        reasons = sorted({(r.refused or "")[:70] for r in kept})
        lines += [f"    {reason}" for reason in reasons[:5]]
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--refine", action="store_true")
    parser.add_argument("--photos", default="3,402")
    parser.add_argument("--seeds", default="0-4")
    args = parser.parse_args(argv)
    lo, hi = (int(s) for s in args.seeds.split("-"))
    for photo in (int(p) for p in args.photos.split(",")):
        print(f"photo {photo}:")
        print(summary(run([photo], range(lo, hi + 1), args.refine)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
