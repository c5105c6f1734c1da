"""The discrepancy detector on BOP LM-O's real photos with plan edits (issue 41): the photo
registered at its ground truth, the plan edited. Run from the repository's root::

    PYTHONPATH=$PWD python tests/lmo_discrepancies.py [--photos 3,402,819]

Per photo (the 8 annotated objects as the plan, world = the first object's frame, the camera at
the ground truth):

* **unchanged**: the plan as the photo shows it; every flagged object is a false suspect;
* **moved**: one object moved 2, 5 or 10 cm along the camera's x axis in the plan; found when it
  is flagged; any other object flagged is a false suspect;
* **deleted**: one object left out of the plan (the photo shows something the plan lacks); found
  when an unexplained region's box covers the object's centre in the photo; objects flagged are
  false suspects;
* **phantom**: a copy of one object added to the plan 20 cm along the camera's x axis from it, where
  its image box meets no other object's (the photo lacks it); found when it is flagged.

Precision counts flags on objects (suspects): true when the object flagged is the one moved or the
phantom. Photo 819 is held out (reported apart).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.apps.discrepancies import detect
from mrcheck.eval.realbench import lmo_splits
from mrcheck.eval.realdata import anchored_scene, lmo_photo, real_root
from mrcheck.render.renderer import Renderer

MOVES_CM = (2.0, 5.0, 10.0)
PHANTOM_CM = 20.0


@dataclass(frozen=True)
class EditCase:
    """One edited plan: ``kind`` (unchanged, moved, deleted, phantom), the object edited and by
    how much, whether the change was found, and the unchanged objects flagged."""

    photo: int
    kind: str
    target: str
    cm: float
    found: bool | None
    false_flags: tuple
    regions: int


def _shifted(obj, cm: float, name: str | None = None):
    pose = obj.pose.copy()
    pose[0, 3] += cm / 100.0
    return dataclasses.replace(obj, pose=pose, name=name or obj.name)


def _box(photo, obj) -> tuple:
    """The object's image box at the ground truth (its vertices projected)."""
    uv = photo.camera.project(obj.vertices[:: max(1, len(obj.vertices) // 2000)] @ obj.pose[:3, :3].T + obj.pose[:3, 3])
    return (*uv.min(axis=0), *uv.max(axis=0))


def _overlap(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _run(photo, image, rgb, objects, kind, target, cm) -> EditCase:
    plan = dataclasses.replace(photo, objects=objects)
    scene, camera = anchored_scene(plan, 0)
    renderer = Renderer(scene)
    try:
        found_now = detect(scene, camera, rgb, renderer=renderer)
    finally:
        renderer.release()
    flagged = {s.part for s in found_now.flagged}
    if kind == "deleted":
        (obj,) = [o for o in photo.objects if o.name == target]
        x0, y0, x1, y1 = _box(photo, obj)
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        found = any(r.bbox[0] <= cx <= r.bbox[2] and r.bbox[1] <= cy <= r.bbox[3] for r in found_now.regions)
    else:
        found = None if kind == "unchanged" else target in flagged
    false = tuple(sorted(flagged - ({target} if kind in ("moved", "phantom") else set())))
    return EditCase(image, kind, target, cm, found, false, len(found_now.regions))


def run(photos, unchanged_only: bool = False) -> list[EditCase]:
    """Every edit of the module docstring on each photo (``unchanged_only``: the unchanged plan)."""
    root, meshes, out = real_root(), {}, []
    for image in photos:
        photo = lmo_photo(root, image, meshes)
        rgb = cv2.cvtColor(cv2.imread(str(photo.photo)), cv2.COLOR_BGR2RGB)
        objects = list(photo.objects)
        out.append(_run(photo, image, rgb, objects, "unchanged", "", 0.0))
        if unchanged_only:
            continue
        boxes = [_box(photo, o) for o in objects]
        for k, obj in enumerate(objects):
            for cm in MOVES_CM:
                edited = objects[:k] + [_shifted(obj, cm)] + objects[k + 1 :]
                out.append(_run(photo, image, rgb, edited, "moved", obj.name, cm))
            if k:  # the first object is the world frame
                out.append(_run(photo, image, rgb, objects[:k] + objects[k + 1 :], "deleted", obj.name, 0.0))
            phantom = _shifted(obj, PHANTOM_CM, f"phantom-{obj.name}")
            box = _box(photo, phantom)
            inside = box[0] >= 0 and box[1] >= 0 and box[2] < photo.camera.width and box[3] < photo.camera.height
            if inside and not any(_overlap(box, b) for b in boxes):
                out.append(_run(photo, image, rgb, [*objects, phantom], "phantom", phantom.name, PHANTOM_CM))
    return out


def summary(cases: list[EditCase]) -> list[str]:
    lines = []
    for kind in ("moved", "deleted", "phantom"):
        mine = [c for c in cases if c.kind == kind]
        for cm in sorted({c.cm for c in mine}):
            some = [c for c in mine if c.cm == cm]
            label = f"{kind} {cm:g} cm" if kind == "moved" else kind
            lines.append(f"  {label}: found {sum(bool(c.found) for c in some)} of {len(some)}")
    flagged_true = sum(bool(c.found) for c in cases if c.kind in ("moved", "phantom"))
    false = sum(len(c.false_flags) for c in cases)
    precision = flagged_true / max(flagged_true + false, 1)
    unchanged = [c for c in cases if c.kind == "unchanged"]
    lines.append(
        f"  flags on objects: {flagged_true} true, {false} false (precision {precision:.2f}); "
        f"false suspects per unchanged photo {np.mean([len(c.false_flags) for c in unchanged]):.1f} "
        f"({', '.join(' '.join(c.false_flags) or '-' for c in unchanged)}); "
        f"regions per photo median {np.median([c.regions for c in cases]):.0f}"
    )
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photos", default="3,402,819")
    args = parser.parse_args(argv)
    cases = run([int(p) for p in args.photos.split(",")])
    for split, mine in lmo_splits(cases):
        print(f"{split}:")
        print("\n".join(summary(mine)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
