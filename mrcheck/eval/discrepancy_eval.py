"""The discrepancy detector's evaluation harness: precision and recall on as-built variants.

Protocol (:func:`evaluate`)
---------------------------
For each seed, :func:`mrcheck.scene.asbuilt.make_asbuilt` writes an as-built variant; for each view
the "photo" is the as-built scene rendered with the ``sun`` light (the planned render uses the
headlight), distorted by a k1 lens through the overlay's mapping, blurred (Gaussian sigma
0.7 px) and with Gaussian noise (sigma 4 grey levels). Detection runs against the planned scene
with that exact camera. A ground-truth discrepancy is *in view* when its instance covers at
least :data:`~mrcheck.apps.discrepancies.thresholds.MIN_EDGE_PIXELS` visible CAD edge pixels in the planned scene
(moved, rotated,
missing, replaced) or, for "added", at least :data:`ADDED_MIN_PIXELS` (50) pixels of the as-built id buffer. It is
*found* when its id is among the suspects (either rule); an added one when an
unexplained region's box overlaps the added instance's box in the as-built id buffer.
Precision = suspects (and regions) that are a ground-truth change / all suspects (and
regions); a suspect whose box overlaps the image box of a change (an object uncovered or
covered by a moved part) counts as "explained" and is reported apart, not as a true positive.
Every item in view is also tallied by its *distance* (median camera depth of its pixels:
``at <10 m``, ``at 10-20 m``, ``at >=20 m``), alone and per kind; ``moved >=0.2 m`` is the
issue's target. Views are viewpoint names or look-at dicts (:data:`SAMPLE_CELL_FAR_VIEWS`).
``precision_counting_uncovered_as_false`` counts those explained suspects as false (issue 41:
every flag on an unchanged part is a false alarm).

Photos by another renderer (``photos="open3d"``): the light fit assumes exactly the shading of
mrcheck's own render, so the same protocol also runs on colour photos ray cast with Open3D
(:func:`mrcheck.eval.edgephotos.synthetic_photo` with ``colour``, no clutter, nothing left out:
the as-built variant as it is): a sun of random elevation (35-65 degrees) and azimuth with cast
shadows, a sky term, the part colours with a smooth world-space texture and grain, the same
camera and k1 lens (rays through the distorted pixels), 2x2 supersampling, blur 0.7 px, noise
sigma 0.02 (5 grey levels). The photo's seed is the variant's (every view of a variant under
one sun), 0 for the unchanged views, as for mrcheck's photos.

Resolution: detection runs at the photo's own size (ids, outlines and Canny all per photo
pixel; the tolerance is 2 px up to 1000 px on the longer side). What limits moves is their image
displacement: at 400x300 moves of 2-8 px (inside the shifted-outline search) were found 1 in 10
held out, those over 8 px 26 in 31; the same scenes photographed at 640x480 push most moves past
8 px. So the evaluation's default size is 640x480; 400x300 figures are kept in docs/discrepancy-evaluation.md for
comparison. Tried and not kept (seeds 0-9): interior crease pixels as extra scored outline (+4
moves but precision 0.71 -> 0.69 at 400x300, 0.70 -> 0.64 at 640x480) and a "best shift >= 2 px
and clearly better" rule (1.5 to 3 times the false suspects for +5 to +10 moves). Interior evidence
(photo edges strictly inside a part's planned region, eroded by tolerance + 2 px, against the
edges of what lies behind it) caught none of the 11 missed moves on seeds 0-9: eroded, most of
those parts have no pixels left at 640x480, and the one with background edges inside (a bollard
in front of a fence, 17 px) showed them as well when it was in place. Still missed (held out):
the machine seen only through the mesh fence (discriminative score 0.55-0.73), a bollard whose
outline the scene behind it explains almost entirely (10 discriminative pixels, below
:data:`~mrcheck.apps.discrepancies.thresholds.MIN_EDGE_PIXELS`), a workbench moved 2 m (0.12) and a bollard at 18 m
moved 5 px (0.51).

Reproduce (seeds 0-9 chose the threshold; 10-19 are the held-out figures in docs/discrepancy-evaluation.md)::

    from mrcheck.eval.discrepancy_eval import SAMPLE_CELL_FAR_VIEWS, evaluate
    from mrcheck.core.resources import sample_scene_path
    print(evaluate(sample_scene_path(), seeds=range(10, 20), views=("overview", "conveyor", *SAMPLE_CELL_FAR_VIEWS),
                   width=640, height=480, workdir="/tmp/eval").summary)

(add ``photos="open3d"`` for the other renderer's photos).
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path

import cv2
import numpy as np

from mrcheck.apps.discrepancies.detector import Detection, detect
from mrcheck.apps.discrepancies.ids import object_ids
from mrcheck.apps.discrepancies.planned import planned_view
from mrcheck.core.camera import Camera
from mrcheck.eval import edgephotos
from mrcheck.mr.lens import distort_to_photo
from mrcheck.mr.shot import render_for_photo
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.model import Scene, load_scene

# issue 22's precision target is judged at the recall over these changes (moved >= 0.2 m,
# missing, added, replaced), the per_kind row TARGET
TARGET = "target (moved >=0.2 m, missing, added, replaced)"
TARGET_KINDS = ("missing", "added", "replaced")
PHOTO_SOURCES = ("mrcheck", "open3d")  # evaluate's ``photos``: who renders the photos
ADDED_MIN_PIXELS = 50  # an added object in view covers at least this many as-built id pixels
# cameras the sample cell does not define, put where most changes lie 10-20 m away (pulled back
# behind the overview, and from the two far corners of the hall)
SAMPLE_CELL_FAR_VIEWS = (
    {"name": "far_overview", "eye": [-17.0, -8.3, 2.2], "target": [4.0, -0.5, 0.3], "fov_y_deg": 45.0},
    {"name": "far_back", "eye": [11.5, 6.5, 2.5], "target": [-3.0, -2.5, 0.5], "fov_y_deg": 50.0},
    {"name": "far_side", "eye": [-11.5, 6.8, 2.5], "target": [3.0, -3.0, 0.5], "fov_y_deg": 50.0},
)


def synthetic_photo(
    scene: Scene, camera: Camera, renderer=None, seed: int = 0, noise: float = 4.0, blur_sigma: float = 0.7
) -> np.ndarray:
    """The as-built "photo": sun light, the camera's lens distortion, blur and noise."""
    own = renderer is None
    renderer = Renderer(scene) if own else renderer
    try:
        # a photo shows every detail; the look the detector was measured on (no AA, clipped tone)
        settings = RenderSettings(light="sun", lod_px=0.0, antialias=False, tone="clip")
        renders, _, offset, maps = render_for_photo(renderer, camera, ["phong"], settings, False)
    finally:
        if own:
            renderer.release()
    photo = distort_to_photo(renders["phong"], maps, offset, (camera.height, camera.width)).astype(np.float32)
    photo = cv2.GaussianBlur(photo, (0, 0), blur_sigma)
    photo += np.random.default_rng(seed).normal(0.0, noise, photo.shape).astype(np.float32)
    return np.clip(np.rint(photo), 0, 255).astype(np.uint8)


def _photo(photos: str, scene: Scene, camera: Camera, renderer, seed: int) -> np.ndarray:
    """(H, W, 3) uint8 RGB photo of ``scene`` by mrcheck's renderer or Open3D's ray casting
    (module docstring); ``renderer`` (of ``scene``) is used for mrcheck's only."""
    if photos == "open3d":
        return edgephotos.synthetic_photo(scene, camera, seed, clutter=0, leave_out=False, colour=True)[0]
    return synthetic_photo(scene, camera, renderer, seed=seed)


@dataclass
class TruthItem:
    """A ground-truth discrepancy in view, and whether the detector found it."""

    id: str
    kind: str
    magnitude: float
    distance: float  # median camera depth of its pixels, m
    found: bool


@dataclass
class Case:
    """One as-built seed seen from one view."""

    seed: int
    view: str
    truth: list[TruthItem]
    suspects: list[tuple[str, float]]  # (id, score) of the suspects proper
    regions: int


@dataclass
class Evaluation:
    """What :func:`evaluate` measured. ``summary`` is the JSON-able table of figures:
    ``photos`` (the renderer of the photos), ``recall``, ``precision``,
    ``precision_counting_explained``, ``precision_counting_uncovered_as_false`` (explained
    suspects counted false), the counts (``false_regions``: the false positives that are
    regions), ``per_kind`` (``{key: {found, in_view, recall}}`` by kind, band and distance),
    ``false_suspects_planned`` (per view, suspects + regions with the planned scene as photo),
    its mean ``false_suspects_planned_mean`` and the regions among them
    ``false_regions_planned``."""

    summary: dict
    cases: list[Case]

    def to_dict(self) -> dict:
        return {"summary": self.summary, "cases": [asdict(c) for c in self.cases]}


def _band(d) -> str:
    kind, mag = d["kind"], d["magnitude"]
    if kind == "moved":
        return "moved <0.2 m" if mag < 0.2 else "moved 0.2-0.5 m" if mag < 0.5 else "moved >=0.5 m"
    if kind == "rotated":
        return "rotated <20 deg" if mag < 20 else "rotated >=20 deg"
    if kind == "replaced":
        return "replaced |s-1|<0.2" if abs(mag - 1) < 0.2 else "replaced |s-1|>=0.2"
    return kind


def _distance_band(depth: float) -> str:
    return "at <10 m" if depth < 10 else "at 10-20 m" if depth < 20 else "at >=20 m"


def _tally_keys(d, depth: float) -> list[str]:
    """Every row of ``per_kind`` a truth item counts in."""
    # dict.fromkeys: for missing and added the band is the kind itself (count once)
    keys = list(
        dict.fromkeys([d["kind"], _band(d), "all", _distance_band(depth), f"{d['kind']} {_distance_band(depth)}"])
    )
    if d["kind"] == "moved" and d["magnitude"] >= 0.2:  # the target
        keys += ["moved >=0.2 m", f"moved >=0.2 m {_distance_band(depth)}"]
    if d["kind"] in TARGET_KINDS or (d["kind"] == "moved" and d["magnitude"] >= 0.2):
        keys.append(TARGET)
    return keys


def _view_camera(scene: Scene, view, width: int, height: int, k1: float) -> tuple[str, Camera]:
    """A viewpoint name of the scene, or ``{"name", "eye", "target", "fov_y_deg"}`` (a camera the
    scene does not define, e.g. one pulled back to put the changes 10-20 m away)."""
    if isinstance(view, str):
        name, cam = view, scene.camera(view, width, height)
    else:
        name = view["name"]
        cam = Camera.from_look_at(
            view["eye"], view["target"], view.get("up", (0, 0, 1)), view.get("fov_y_deg", 60.0), width, height
        )
    return name, Camera(cam.width, cam.height, cam.K, cam.R, cam.t, np.array([k1, 0.0, 0.0, 0.0]))


def _overlap(a, b) -> bool:
    return a[0] <= b[2] and b[0] <= a[2] and a[1] <= b[3] and b[1] <= a[3]


def _ratio(a, b):
    return round(a / b, 3) if b else None


@dataclass
class _Tally:
    """Running counts over every case: per key [found, in view]; suspects judged; per unchanged
    view the flags (suspects + regions) and the regions among them."""

    counts: dict = field(default_factory=dict)
    tp: int = 0
    fp: int = 0
    explained: int = 0
    false_regions: int = 0  # of fp: unexplained regions (shadows, texture) rather than parts
    planned_false: list = field(default_factory=list)
    planned_regions: list = field(default_factory=list)

    def add(self, keys, hit: bool) -> None:
        for key in keys:
            t = self.counts.setdefault(key, [0, 0])
            t[0] += int(hit)
            t[1] += 1

    def judge(self, detection: Detection, truth_ids: set, changed_boxes: list) -> None:
        """Suspects that are a change (true), overlap one's box (explained) or neither (false);
        regions that overlap a change's box (true) or not (false)."""
        for s in detection.flagged:
            if s.id in truth_ids:
                self.tp += 1
            elif any(_overlap(s.bbox, b) for b in changed_boxes):
                self.explained += 1
            else:
                self.fp += 1
        for r in detection.regions:
            if any(_overlap(r.bbox, b) for b in changed_boxes):
                self.tp += 1
            else:
                self.fp += 1
                self.false_regions += 1

    def judge_planned(self, detection: Detection) -> None:
        """An unchanged view: every suspect and region is false."""
        self.planned_false.append(len(detection.flagged) + len(detection.regions))
        self.planned_regions.append(len(detection.regions))

    def summary(self, photos: str) -> dict:
        tp, fp, explained, planned_false = self.tp, self.fp, self.explained, self.planned_false
        return {
            "photos": photos,
            "recall": _ratio(*self.counts.get("all", [0, 0])),
            "precision": _ratio(tp, tp + fp),
            "precision_counting_explained": _ratio(tp + explained, tp + fp + explained),
            # issue 41: a part a change uncovered or stands next to is unchanged, its flag false
            "precision_counting_uncovered_as_false": _ratio(tp, tp + fp + explained),
            "true_positives": tp,
            "false_positives": fp,
            "false_regions": self.false_regions,
            "explained_neighbours": explained,
            "per_kind": {
                k: {"found": v[0], "in_view": v[1], "recall": _ratio(*v)} for k, v in sorted(self.counts.items())
            },
            "false_suspects_planned": planned_false,
            "false_suspects_planned_mean": _ratio(sum(planned_false), len(planned_false)),
            "false_regions_planned": self.planned_regions,
        }


def _truth_seen(d, detection: Detection, built) -> tuple[list, bool, float] | None:
    """(image box, found, distance) of truth item ``d`` when it is in view, else None. ``built``:
    the as-built scene's :func:`~mrcheck.apps.discrepancies.ids.object_ids` (for added objects)."""
    if d["kind"] == "added":
        bids, bdepth, blabels = built
        idx = [i for i, lab in enumerate(blabels) if lab[1] == d["id"]]
        ys, xs = np.nonzero(bids == idx[0]) if idx else (np.array([]), np.array([]))
        if len(ys) < ADDED_MIN_PIXELS:
            return None
        box = [xs.min(), ys.min(), xs.max(), ys.max()]
        return box, any(_overlap(box, r.bbox) for r in detection.regions), float(np.median(bdepth[ys, xs]))
    scored = {s.id: s for s in detection.suspects}
    if d["id"] not in scored:
        return None  # out of view, hidden, or too small to judge
    planned = detection.planned
    index = {lab[1]: i for i, lab in enumerate(planned.labels)}[d["id"]]
    return scored[d["id"]].bbox, scored[d["id"]].suspect, float(np.median(planned.depth[planned.ids == index]))


def _case(seed: int, view: str, detection: Detection, truth: list, built, tally: _Tally) -> Case:
    """Judge one detection against the seed's ground truth, counting into ``tally``."""
    changed_boxes, found = [], []
    for d in truth:
        seen = _truth_seen(d, detection, built)
        if seen is None:
            continue
        box, hit, depth = seen
        changed_boxes.append(box)
        tally.add(_tally_keys(d, depth), hit)
        found.append(TruthItem(d["id"], d["kind"], d["magnitude"], round(depth, 2), bool(hit)))
    tally.judge(detection, {d["id"] for d in truth}, changed_boxes)
    return Case(seed, view, found, [(s.id, s.score) for s in detection.flagged], len(detection.regions))


def _seed_cases(
    planned_path: Path,
    seed: int,
    root: Path,
    scene: Scene,
    cameras: dict,
    views: dict,
    ctx,
    tolerance_px,
    tally: _Tally,
    photos: str,
) -> list[Case]:
    """Make the as-built variant of ``seed``, photograph it from every view (by ``photos``'s
    renderer) and judge each."""
    from mrcheck.scene.asbuilt import make_asbuilt

    out = root / f"asbuilt_{seed}"
    make_asbuilt(planned_path, out, seed=seed)
    built = load_scene(out / "scene.toml")
    truth = json.loads((out / "discrepancies.json").read_text())["discrepancies"]
    renderer = Renderer(built, ctx=ctx) if photos == "mrcheck" else None
    try:
        cases = []
        for view, camera in cameras.items():
            photo = _photo(photos, built, camera, renderer, seed)
            detection = detect(scene, camera, photo, tolerance_px, planned=views[view])
            cases.append(_case(seed, view, detection, truth, object_ids(built, camera), tally))
        return cases
    finally:
        if renderer is not None:
            renderer.release()


def evaluate(
    planned,
    seeds=(0, 1, 2),
    views=("overview", "conveyor"),
    width=640,
    height=480,
    k1=-0.12,
    workdir=None,
    ctx=None,
    tolerance_px=None,
    photos="mrcheck",
) -> Evaluation:
    """Precision / recall of the detector on as-built variants (protocol: module docstring).

    ``views``: viewpoint names or look-at dicts (:data:`SAMPLE_CELL_FAR_VIEWS`); ``workdir``:
    where the variants are written (a temporary folder when None); ``ctx``: a moderngl context
    to render with; ``photos``: who renders the photos, one of :data:`PHOTO_SOURCES` (mrcheck's
    renderer, or Open3D's ray casting). The planned scene as its own photo gives
    ``false_suspects_planned``.
    """
    if photos not in PHOTO_SOURCES:
        raise ValueError(f"photos must be one of {PHOTO_SOURCES}, got {photos!r}")
    planned = Path(planned)
    scene = load_scene(planned)
    tmp = tempfile.TemporaryDirectory() if workdir is None else None
    root = Path(tmp.name if tmp else workdir)
    tally, cases = _Tally(), []
    renderer = Renderer(scene, ctx=ctx)
    try:
        cameras = dict(_view_camera(scene, view, width, height, k1) for view in views)
        planned_views = {view: planned_view(scene, camera, renderer) for view, camera in cameras.items()}
        for view, camera in cameras.items():
            photo = _photo(photos, scene, camera, renderer, 0)
            tally.judge_planned(detect(scene, camera, photo, tolerance_px, planned=planned_views[view]))
        for seed in seeds:
            cases += _seed_cases(planned, seed, root, scene, cameras, planned_views, ctx, tolerance_px, tally, photos)
    finally:
        renderer.release()
        if tmp:
            tmp.cleanup()
    return Evaluation(tally.summary(photos), cases)


__all__ = ["evaluate", "Evaluation", "Case", "TruthItem", "synthetic_photo", "SAMPLE_CELL_FAR_VIEWS", "PHOTO_SOURCES"]
