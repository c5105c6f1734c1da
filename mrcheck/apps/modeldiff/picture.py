"""A view of two revisions: the NEW model rendered with vector AO from a camera, the changes of
the element diff drawn over it.

* unchanged elements: the vector-AO render in grey (its brightness), so that no part colour is
  mistaken for a change;
* added: green, changed geometry: blue, moved: amber -- where NEW shows them (the tint times the
  render's brightness, so AO still gives the depth), and at :data:`HIDDEN_ALPHA` where other
  elements hide them (an added column inside a building still shows);
* removed: red, ghosted from OLD: drawn at :data:`FRONT_ALPHA` where nothing of NEW is in front
  of it, at :data:`HIDDEN_ALPHA` where NEW hides it;
* moved: the outline of the element where OLD had it, and an arrow from its old to its new box
  centre, labelled with the distance and the rotation;
* every change in the view's frustum: a frame of its colour around its box (seen or hidden),
  so that small and far changes are found.

Which pixels an element set covers comes from rendering that set alone with the same camera and
comparing its depth with the whole model's (:func:`visible`): a handful of changed elements
cost little, where an id buffer of the whole model (a ray caster over every triangle of a 5 M
triangle hall) would cost seconds per view.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.apps.modeldiff.compare import ModelDiff
from mrcheck.core.camera import Camera
from mrcheck.scene.model import Scene

COLOURS = {  # RGB
    "added": (60, 200, 80),
    "removed": (230, 45, 45),
    "moved": (255, 176, 0),
    "changed geometry": (70, 140, 255),
}
FRONT_ALPHA = 0.7  # a removed element where nothing of NEW hides it
HIDDEN_ALPHA = 0.4  # a changed element behind NEW's surfaces (x-ray)
DEPTH_TOLERANCE = (0.002, 0.002)  # same surface: depths within 2 mm + 0.2 % of the depth
MIN_ARROW_PX = 4.0  # shorter moves get their label only
MIN_FRAME_PX = 24.0  # the smallest frame around a change, pixels at 640 wide
LEGEND_HEIGHT = 28  # pixels of the legend strip at 640 pixels wide


@dataclass(frozen=True)
class ViewPicture:
    """One view's picture and where each change shows in it: ``boxes`` maps a change's id to its
    pixel box (x0, y0, x1, y1) in ``image`` (its box's corners projected; only changes in view)."""

    name: str
    camera: Camera
    image: np.ndarray
    boxes: dict


def subset(scene: Scene, ids) -> Scene | None:
    """The scene with only the instances in ``ids`` (None when there are none)."""
    wanted = set(ids)
    parts = []
    for part in scene.parts:
        keep = [k for k, i in enumerate(part.instance_ids) if i in wanted]
        if keep:
            parts.append(
                dataclasses.replace(
                    part,
                    transforms=part.transforms[keep],
                    instance_ids=[part.instance_ids[k] for k in keep],
                    instance_info=[part.instance_info[k] for k in keep],
                )
            )
    return dataclasses.replace(scene, parts=parts) if parts else None


def render_depth(scene: Scene | None, camera: Camera, ctx) -> np.ndarray:
    """(H, W) float32 linear depth of ``scene`` alone (0: nothing; all 0 for None)."""
    from mrcheck.render.renderer import Renderer, RenderSettings

    if scene is None:
        return np.zeros((camera.height, camera.width), np.float32)
    renderer = Renderer(scene, ctx)
    try:
        return renderer.render(camera, ["phong"], RenderSettings(antialias=False, lod_px=0.0)).depth
    finally:
        renderer.release()


def visible(depth_of_set: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """Pixels where the set's surface is the model's visible one (the same depth)."""
    near, relative = DEPTH_TOLERANCE
    return (depth_of_set > 0) & (np.abs(depth_of_set - depth) <= near + relative * depth)


def _tint(image: np.ndarray, shade: np.ndarray, mask: np.ndarray, colour) -> None:
    """The colour times the render's brightness on ``mask`` (AO darkens the tint, in place)."""
    image[mask] = np.clip(np.asarray(colour, np.float64) * (1.2 * shade[mask]) ** 1.5, 0, 255)


def _blend(image: np.ndarray, mask: np.ndarray, colour, alpha: float) -> None:
    image[mask] = (1.0 - alpha) * image[mask] + alpha * np.asarray(colour, np.float64)


def _in_front(camera: Camera, points: np.ndarray) -> np.ndarray:
    return (np.asarray(points, np.float64) @ camera.R.T + camera.t)[:, 2] > 1e-3


def pixel_box(camera: Camera, corners: np.ndarray) -> tuple | None:
    """The pixel box of world box corners, clipped to the image; None when not in view."""
    if not _in_front(camera, corners).all():
        return None  # partly behind the camera: its projection is not a box
    uv = camera.project(corners)
    x0, y0 = np.floor(uv.min(axis=0)).astype(int)
    x1, y1 = np.ceil(uv.max(axis=0)).astype(int)
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, camera.width - 1), min(y1, camera.height - 1)
    return (int(x0), int(y0), int(x1), int(y1)) if x0 <= x1 and y0 <= y1 else None


def _move_label(change) -> str:
    parts = []
    if change.distance_m and change.distance_m > 0.0005:
        parts.append(f"{change.distance_m:.3f} m")
    if change.rotation_deg:
        parts.append(f"{change.rotation_deg:.1f} deg")
    return ", ".join(parts)


def _text(image: np.ndarray, text: str, at, scale: float, colour=(255, 255, 255)) -> None:
    """Text with a dark outline, readable over any render."""
    font, org = cv2.FONT_HERSHEY_SIMPLEX, (int(at[0]), int(at[1]))
    thickness = max(1, int(round(scale * 1.5)))
    cv2.putText(image, text, org, font, scale, (0, 0, 0), thickness + 2, cv2.LINE_AA)
    cv2.putText(image, text, org, font, scale, colour, thickness, cv2.LINE_AA)


def _draw_moves(image: np.ndarray, camera: Camera, moves, scale: float) -> None:
    """An arrow from each moved element's old box centre to its new one, and its label."""
    width = max(2, int(round(2 * scale)))
    for change in moves:
        ends = np.array([change.old_centre, change.new_centre], np.float64)
        if not _in_front(camera, ends).all():
            continue
        (u0, v0), (u1, v1) = camera.project(ends)
        if max(abs(u0), abs(v0), abs(u1), abs(v1)) > 1e5:
            continue
        if np.hypot(u1 - u0, v1 - v0) >= MIN_ARROW_PX:
            start, end = (int(round(u0)), int(round(v0))), (int(round(u1)), int(round(v1)))
            tip = min(0.3, 12.0 * scale / max(np.hypot(u1 - u0, v1 - v0), 1.0))
            cv2.arrowedLine(image, start, end, (0, 0, 0), width + 2, cv2.LINE_AA, tipLength=tip)
            cv2.arrowedLine(image, start, end, COLOURS["moved"], width, cv2.LINE_AA, tipLength=tip)
        label = _move_label(change)
        if label:
            _text(image, label, (u1 + 6 * scale, v1 - 6 * scale), 0.45 * scale, COLOURS["moved"])


def _frame(image: np.ndarray, box, colour, scale: float) -> None:
    """A frame around a change's pixel box, at least :data:`MIN_FRAME_PX` across: in a hall a
    changed pallet 80 m away is a few pixels, and the frame is what finds it."""
    x0, y0, x1, y1 = box
    half = MIN_FRAME_PX * scale / 2.0
    cx, cy = (x0 + x1) / 2.0, (y0 + y1) / 2.0
    x0, x1 = int(min(x0, cx - half)) - 3, int(max(x1, cx + half)) + 3
    y0, y1 = int(min(y0, cy - half)) - 3, int(max(y1, cy + half)) + 3
    width = max(1, int(round(scale)))
    cv2.rectangle(image, (x0, y0), (x1, y1), (0, 0, 0), width + 2, cv2.LINE_AA)
    cv2.rectangle(image, (x0, y0), (x1, y1), colour, width, cv2.LINE_AA)


def _outline(image: np.ndarray, mask: np.ndarray, colour, scale: float) -> None:
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    cv2.drawContours(image, contours, -1, colour, max(1, int(round(scale))), cv2.LINE_AA)


def legend(width: int, counts: dict, scale: float) -> np.ndarray:
    """The strip under the picture: a swatch and the count in view of each kind of change."""
    height = int(round(LEGEND_HEIGHT * scale))
    strip = np.full((height, width, 3), 40, np.uint8)
    labels = [f"{kind} {counts.get(kind, 0)}" for kind in COLOURS]
    side, gap = height // 2, int(6 * scale)
    font = 0.45 * scale
    widths = [cv2.getTextSize(t, cv2.FONT_HERSHEY_SIMPLEX, font, max(1, int(round(font * 1.5))))[0][0] for t in labels]
    room = (width - sum(w + side + 3 * gap for w in widths)) / (len(labels) + 1)
    x = max(room, 2.0)
    for label, colour, text_width in zip(labels, COLOURS.values(), widths):
        cv2.rectangle(strip, (int(x), height // 4), (int(x) + side, height // 4 + side), colour, -1)
        org = (int(x + side + gap), int(height * 0.7))  # on the dark strip: no outline needed
        cv2.putText(strip, label, org, cv2.FONT_HERSHEY_SIMPLEX, font, (235, 235, 235), 1, cv2.LINE_AA)
        x += text_width + side + 3 * gap + max(room, 2.0)
    return strip


class Painter:
    """Draws the views of one diff: NEW's renderer is made once (its upload is the cost of a
    large model) and serves every view; the changed sets are rendered per view."""

    def __init__(self, old: Scene, new: Scene, diff: ModelDiff, ctx):
        from mrcheck.render.renderer import Renderer

        self.old, self.new, self.diff, self.ctx = old, new, diff, ctx
        self.by_kind = {kind: [c.id for c in diff.changes if c.kind == kind] for kind in COLOURS}
        self.sets = {kind: subset(old if kind == "removed" else new, ids) for kind, ids in self.by_kind.items()}
        self.moved_from = subset(old, self.by_kind["moved"])
        self.boxes_of = change_corners(old, new, diff)
        self.renderer = Renderer(new, ctx)

    def release(self) -> None:
        self.renderer.release()

    def view(self, name: str, camera: Camera) -> ViewPicture:
        """The picture of one view (module docstring). Every part at full detail (``lod_px`` 0):
        building levels of detail costs more than a few frames save (the 5 M-triangle hall:
        45 s of levels against 4 views), unless a persistent cache already holds them."""
        from mrcheck.render.renderer import RenderSettings

        frame = self.renderer.render(camera, ["vector"], RenderSettings(lod_px=0.0))
        render, depth = frame["vector"].image, frame.depth
        shade = render.astype(np.float64).mean(axis=2) / 255.0
        image = np.repeat((shade * 255.0)[..., None], 3, axis=2)
        for kind in ("added", "changed geometry", "moved"):
            drawn = render_depth(self.sets[kind], camera, self.ctx)
            mask = visible(drawn, depth)
            _tint(image, shade[..., None], mask, COLOURS[kind])
            _blend(image, (drawn > 0) & ~mask, COLOURS[kind], HIDDEN_ALPHA)  # behind other elements: x-ray
        gone = render_depth(self.sets["removed"], camera, self.ctx)
        front = (gone > 0) & ((depth == 0) | (gone < depth))
        _blend(image, front, COLOURS["removed"], FRONT_ALPHA)
        _blend(image, (gone > 0) & ~front, COLOURS["removed"], HIDDEN_ALPHA)
        image = image.astype(np.uint8)
        scale = max(camera.width / 640.0, 0.6)
        _outline(image, render_depth(self.moved_from, camera, self.ctx) > 0, COLOURS["moved"], scale)
        _draw_moves(image, camera, [c for c in self.diff.changes if c.kind == "moved"], scale)
        boxes = {i: box for i, corners in self.boxes_of.items() if (box := pixel_box(camera, corners)) is not None}
        kinds = {c.id: c.kind for c in self.diff.changes}
        for change_id, box in boxes.items():
            _frame(image, box, COLOURS[kinds[change_id]], scale)
        counts = {kind: sum(i in boxes for i in ids) for kind, ids in self.by_kind.items()}
        return ViewPicture(name, camera, np.vstack([image, legend(camera.width, counts, scale)]), boxes)


def change_corners(old: Scene, new: Scene, diff: ModelDiff) -> dict:
    """{change id: (8, 3) world box corners}: the NEW element's box, the OLD one's if removed."""
    from mrcheck.apps.modeldiff.elements import scene_elements

    before, after = scene_elements(old), scene_elements(new)
    return {c.id: (before[c.id] if c.kind == "removed" else after[c.id]).corners() for c in diff.changes}


def diff_picture(old: Scene, new: Scene, diff: ModelDiff, name: str, camera: Camera, ctx) -> ViewPicture:
    """The picture of one view; ``ctx``: the GL context the renders share. Several views of one
    diff: :class:`Painter`."""
    painter = Painter(old, new, diff, ctx)
    try:
        return painter.view(name, camera)
    finally:
        painter.release()


__all__ = [
    "ViewPicture",
    "Painter",
    "diff_picture",
    "subset",
    "visible",
    "pixel_box",
    "change_corners",
    "legend",
    "COLOURS",
]
