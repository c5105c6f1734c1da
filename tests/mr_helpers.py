"""Shared helpers of the mixed-reality tests: cameras, synthetic photos, ArUco markers as scene parts."""

from __future__ import annotations

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.mr.lens import distort_to_photo
from mrcheck.mr.shot import render_for_photo
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.model import make_part

from .conftest import box


def make_camera(width, height, f, dist=(), eye=None, target=None, principal=(0.0, 0.0)):
    """A camera of focal length ``f`` (pixels), optionally looking from ``eye`` at ``target``."""
    R, t = np.eye(3), np.zeros(3)
    if eye is not None:
        look = Camera.from_look_at(eye, target, (0, 0, 1), 60.0, width, height)
        R, t = look.R, look.t
    K = np.array([[f, 0.0, (width - 1) / 2 + principal[0]], [0.0, f, (height - 1) / 2 + principal[1]], [0, 0, 1]])
    return Camera(width, height, K, R, t, np.asarray(dist, np.float64))


def render_photo(ctx, scene, camera, supersample=1) -> np.ndarray:
    """A synthetic photo: the ideal render of ``camera`` distorted by its lens (optionally
    rendered at ``supersample`` x the size and area-averaged, for cleaner marker edges)."""
    big = camera.resized(camera.width * supersample, camera.height * supersample)
    # the photo's own supersampling and a camera's clipped whites, not the CAD view's filmic look
    settings = RenderSettings(antialias=False, tone="clip")
    renders, _, offset, maps = render_for_photo(Renderer(scene, ctx=ctx), big, ["phong"], settings, False)
    photo = distort_to_photo(renders["phong"], maps, offset)
    if supersample > 1:
        photo = cv2.resize(photo, (camera.width, camera.height), interpolation=cv2.INTER_AREA)
    return photo


DICTIONARY = "DICT_6X6_250"


def marker_parts(markers):
    """Two parts (white plates, black cells) for markers given as (id, centre, right, down, size).

    A plate is the marker plus one white cell of quiet zone on every side; each black cell is a
    thin box standing 1 mm proud of the plate toward the viewer; the map's corners are on the
    cells' top faces. Returns (parts, marker map).
    """
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, DICTIONARY))
    white, black, entries = [], [], []
    for marker_id, centre, right, down, size in markers:
        centre, right, down = (np.asarray(a, np.float64) for a in (centre, right, down))
        right, down = right / np.linalg.norm(right), down / np.linalg.norm(down)
        normal = np.cross(down, right)  # toward the viewer for a marker read the right way round
        pattern = dictionary.generateImageMarker(marker_id, 8)  # 6x6 cells + black border, 1 px each
        cell = size / 8.0
        frame = np.column_stack((right, down, normal))

        def slab(ci, cj, ni, nj, lift, thickness):
            # cells ci..ci+ni (columns), cj..cj+nj (rows) of the 8x8 grid, origin at the top left
            local = np.array([(ci + ni / 2) * cell - size / 2, (cj + nj / 2) * cell - size / 2, lift])
            m = box((ni * cell, nj * cell, thickness), local)
            m.apply_transform(np.vstack([np.column_stack((frame, centre)), [0, 0, 0, 1]]))
            return m

        white.append(slab(-1, -1, 10, 10, -0.005, 0.01))  # plate front face in the marker's plane
        black += [slab(i, j, 1, 1, 0.0, 0.002) for j in range(8) for i in range(8) if pattern[j, i] < 128]
        face = centre + 0.001 * normal  # the black cells' top faces, what the camera sees
        corners = [face + (sx * right + sy * down) * size / 2 for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        entries.append({"id": marker_id, "corners": [c.tolist() for c in corners]})

    def part(name, meshes, color):
        vertices = np.concatenate([m.vertices for m in meshes])
        offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
        faces = np.concatenate([m.faces + o for m, o in zip(meshes, offsets)])
        return make_part(name, "markers", vertices, faces, np.eye(4), color=color)

    return [part("marker_plates", white, (1.0, 1.0, 1.0)), part("marker_cells", black, (0.0, 0.0, 0.0))], {
        "dictionary": DICTIONARY,
        "markers": entries,
    }


def sample_shot(ctx, root, camera, name: str = "p1"):
    """A registered shot of the sample cell in folder ``root`` (made if needed): its synthetic
    photo NAME.png and NAME.json (the camera and the photo's name), as ``mrcheck review SCENE
    --shots ROOT`` reads; returns ``root``."""
    import json

    from mrcheck.core.output import write_image
    from mrcheck.core.resources import sample_scene_path
    from mrcheck.scene.model import load_scene

    root.mkdir(parents=True, exist_ok=True)
    write_image(root / f"{name}.png", render_photo(ctx, load_scene(sample_scene_path()), camera))
    (root / f"{name}.json").write_text(json.dumps({**camera.to_dict(), "photo": f"{name}.png"}))
    return root


def standing_marker(camera, pixel, distance: float, size: float = 0.4, marker_id: int = 0) -> dict:
    """A ``size``-metre marker standing upright ``distance`` metres from ``camera`` on the ray
    through ``pixel``, facing the camera (as on a column or a stand): a marker map."""
    direction = camera.R.T @ np.linalg.solve(camera.K, np.array([pixel[0], pixel[1], 1.0]))
    centre = camera.center + direction / np.linalg.norm(direction) * distance
    right = camera.R[0] * np.array([1.0, 1.0, 0.0])  # the camera's right, level
    right /= np.linalg.norm(right)
    down = np.array([0.0, 0.0, -1.0])
    corners = [centre + (sx * right + sy * down) * size / 2 for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    return {"dictionary": DICTIONARY, "markers": [{"id": marker_id, "corners": [c.tolist() for c in corners]}]}


def paste_marker(photo: np.ndarray, camera, marker_map: dict) -> np.ndarray:
    """``photo`` with the map's first marker painted in (a pinhole ``camera``: projected corners,
    a perspective warp of the pattern with one white cell of quiet zone around it)."""
    entry = marker_map["markers"][0]
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, marker_map["dictionary"]))
    cell = 40
    pattern = cv2.resize(
        dictionary.generateImageMarker(entry["id"], 8), (8 * cell, 8 * cell), interpolation=cv2.INTER_NEAREST
    )
    framed = cv2.copyMakeBorder(pattern, cell, cell, cell, cell, cv2.BORDER_CONSTANT, value=255)
    world = np.asarray(entry["corners"], np.float64)
    centre = world.mean(axis=0)
    quiet = centre + (world - centre) * 10.0 / 8.0  # the white border's outer corners
    image_pts = camera.project(quiet).astype(np.float32)
    source = np.float32([[0, 0], [10 * cell, 0], [10 * cell, 10 * cell], [0, 10 * cell]])
    warp = cv2.getPerspectiveTransform(source, image_pts)
    h, w = photo.shape[:2]
    painted = cv2.warpPerspective(framed, warp, (w, h), flags=cv2.INTER_AREA)
    mask = cv2.warpPerspective(np.full_like(framed, 255), warp, (w, h), flags=cv2.INTER_AREA) / 255.0
    out = photo.astype(np.float64) * (1 - mask[..., None]) + painted[..., None] * mask[..., None]
    return out.round().astype(np.uint8)
