"""The review's "Add photo": a photo and its intrinsics (files of the reviewed folder, or
uploaded), CAD views to click on, the solve of the clicks (:mod:`.clicks`) with its overlay, and
the shot saved into the review.

Files are named by reference, never by a client-given path: ``folder:NAME`` is a file directly
in the folder shots are added to (:func:`added_folder`) and listed by :meth:`AddPhoto.files`;
``upload:ID`` one uploaded in this server's life, staged in the render cache's ``.uploads``
folder (a name no shot folder can have). Saving never overwrites a file: the SHOT.json, and the
photo copied beside it when it was uploaded, get free names (``NAME-2.json``, ...).
"""

from __future__ import annotations

import collections
import re
import secrets
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mrcheck.apps.names import shot_name
from mrcheck.apps.review.clicks import ClickSolve, cad_points, solve_clicks
from mrcheck.apps.review.source import ADDED_SHOTS, Shot
from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import CAMERA_SUFFIXES, read_camera, read_photo
from mrcheck.core.errors import MrcheckError, display
from mrcheck.core.images import decode_image, encode_image
from mrcheck.core.output import IMAGE_SUFFIXES
from mrcheck.core.shot import write_shot
from mrcheck.mr.edges import EdgeOptions, refine_pose, scene_edges
from mrcheck.mr.lens import distort_to_photo, distortion_map, padded_camera
from mrcheck.mr.overlay import DEFAULT_EDGE_COLOR, draw_edges, overlay_images
from mrcheck.mr.shot import cad_edges
from mrcheck.render.settings import RenderSettings

UPLOADS = ".uploads"  # in the render cache: a shot name never starts with a dot
MAX_KEPT = 16  # uploads and solves kept (the oldest are forgotten)
VIEW_WIDTH = 800  # CAD views are rendered at most this wide
SERVED_WIDTH = 1280  # a photo is shown at most this wide (the page stretches it back)
PHOTO_ALPHA = 0.5  # the overlay: photo and CAD half and half, CAD edges on top ...
EDGE_OPACITY = 0.6  # ... at this opacity
_ID = re.compile(r"[0-9a-f]{16}")


def added_folder(source) -> Path:
    """Where added shots go: the shots folder of ``SCENE --shots DIR`` (the review reads its
    SHOT.json files), else ``added-shots/`` beside the job or in the export folder (read at the
    next start too, :func:`mrcheck.apps.review.source.open_source`)."""
    origin = Path(source.origin)
    return origin if source.kind == "scene" else Path(source.home) / ADDED_SHOTS


@dataclass(frozen=True)
class View:
    """A CAD view to click on: a name for the API, a label for people, a pinhole camera."""

    name: str
    label: str
    camera: Camera


def _pinhole(camera: Camera) -> Camera:
    """``camera`` without lens distortion, at most :data:`VIEW_WIDTH` wide."""
    camera = Camera(camera.width, camera.height, camera.K, camera.R, camera.t)
    if camera.width <= VIEW_WIDTH:
        return camera
    return camera.resized(VIEW_WIDTH, max(1, round(VIEW_WIDTH * camera.height / camera.width)))


def overview_camera(bounds: np.ndarray) -> Camera:
    """A view of the whole scene from above one corner of its bounds (for a scene without views)."""
    centre, extent = bounds.mean(axis=0), max(float(np.linalg.norm(bounds[1] - bounds[0])), 1e-3)
    eye = centre + extent * np.array([-0.65, -0.9, 0.72])
    return Camera.from_look_at(eye, centre, (0, 0, 1), 45.0, 640, 480)


def cad_views(source) -> dict[str, View]:
    """The views offered: every shot's camera, the scene's named viewpoints, an overview."""
    scene = source.loaded
    views = {
        f"shot:{s.name}": View(f"shot:{s.name}", f"shot {s.name}", _pinhole(s.camera)) for s in source.shots.values()
    }
    for name in scene.viewpoints:
        views[f"view:{name}"] = View(f"view:{name}", f"viewpoint {name}", _pinhole(scene.camera(name)))
    views["overview"] = View("overview", "overview", overview_camera(scene.bounds()))
    return views


@dataclass
class Solved:
    """A solve kept until it is saved: the result, the photo's reference and file, the overlay."""

    solve: ClickSolve
    photo_ref: str
    photo: Path
    photo_name: str  # the name shown (an upload's own file name)
    overlay: bytes


class AddPhoto:
    """The state of "Add photo" in one review app (``Review.addphoto``)."""

    def __init__(self, review, cache: Path):
        self.review = review
        self.uploads = Path(cache) / UPLOADS
        self._staged: collections.OrderedDict = collections.OrderedDict()  # id -> (path, name, kind)
        self._solved: collections.OrderedDict = collections.OrderedDict()  # id -> Solved
        self._renders: dict = {}  # view name -> PNG
        self._edges = None
        self._lock = threading.Lock()
        for old in self.uploads.glob("*") if self.uploads.is_dir() else ():  # an earlier server's: unreachable now
            if _ID.fullmatch(old.stem):
                old.unlink(missing_ok=True)

    @property
    def folder(self) -> Path:
        return added_folder(self.review.source)

    # -- files ---------------------------------------------------------------------------
    def files(self) -> dict:
        """The photos and camera files directly in the folder shots are added to."""
        folder = self.folder
        names = sorted(p.name for p in folder.iterdir() if p.is_file()) if folder.is_dir() else []
        return {
            "folder": display(folder),
            "photos": [n for n in names if Path(n).suffix.lower() in IMAGE_SUFFIXES],
            "cameras": [n for n in names if Path(n).suffix.lower() in CAMERA_SUFFIXES],
        }

    def upload(self, kind: str, filename: str, data: bytes) -> dict:
        """Stage an uploaded photo or camera file, checked first: ``{"ref", "name"}``."""
        name = Path(filename.replace("\\", "/")).name
        suffix = Path(name).suffix.lower()
        allowed = IMAGE_SUFFIXES if kind == "photo" else CAMERA_SUFFIXES
        if suffix not in allowed:
            raise MrcheckError(f"a {kind} file must end in {', '.join(allowed)}", display(name))
        if kind == "photo":  # not an image, or one of too many pixels: a one-line error, nothing kept
            decode_image(data, display(name), "photo", max_pixels=self.review.source.max_pixels)
        ident = secrets.token_hex(8)
        self.uploads.mkdir(parents=True, exist_ok=True)
        path = self.uploads / f"{ident}{suffix}"
        path.write_bytes(data)
        if kind == "intrinsics":
            try:
                read_camera(path)
            except MrcheckError as exc:
                path.unlink(missing_ok=True)
                raise MrcheckError(exc.problem, display(name)) from None
        with self._lock:
            self._staged[ident] = (path, name, kind)
            while len(self._staged) > MAX_KEPT:
                self._staged.popitem(last=False)[1][0].unlink(missing_ok=True)
        return {"ref": f"upload:{ident}", "name": name}

    def resolve(self, kind: str, ref: str) -> tuple[Path, str]:
        """(file, name shown) of a ``folder:NAME`` or ``upload:ID`` reference, or a one-line error."""
        where, _, name = str(ref).partition(":")
        if where == "upload" and _ID.fullmatch(name) and name in self._staged and self._staged[name][2] == kind:
            return self._staged[name][0], self._staged[name][1]
        if where == "folder":
            listed = self.files()["photos" if kind == "photo" else "cameras"]
            if name in listed:
                return self.folder / name, name
            raise MrcheckError(f"no {kind} file {name!r} in the folder {display(self.folder)}")
        raise MrcheckError(f"unknown {kind} reference {ref!r} (upload it again)")

    def photo_and_camera(self, photo_ref: str, intrinsics_ref: str):
        """(photo file, RGB image, intrinsics) of two references, each checked."""
        photo, _ = self.resolve("photo", photo_ref)
        path, name = self.resolve("intrinsics", intrinsics_ref)
        try:
            camera = read_camera(path)
        except MrcheckError as exc:
            raise MrcheckError(exc.problem, name) from None
        return photo, read_photo(photo, max_pixels=self.review.source.max_pixels), camera

    def photo_name(self, photo_ref: str) -> str:
        return self.resolve("photo", photo_ref)[1]

    def photo_png(self, photo_ref: str) -> tuple[bytes, tuple[int, int]]:
        """The photo as PNG, at most :data:`SERVED_WIDTH` wide, and its native (width, height)."""
        import cv2

        photo, _ = self.resolve("photo", photo_ref)
        image = read_photo(photo, max_pixels=self.review.source.max_pixels)
        h, w = image.shape[:2]
        if w > SERVED_WIDTH:
            image = cv2.resize(image, (SERVED_WIDTH, max(1, round(SERVED_WIDTH * h / w))), interpolation=cv2.INTER_AREA)
        return encode_image("photo.png", image), (w, h)

    # -- CAD views ------------------------------------------------------------------------
    def view(self, name: str) -> View:
        views = cad_views(self.review.source)
        if name not in views:
            raise MrcheckError(f"no CAD view {name!r} (the review has: {', '.join(views)})")
        return views[name]

    def view_png(self, name: str) -> bytes:
        view = self.view(name)
        if name not in self._renders:
            settings = self.review.renders.settings(view.camera.height)

            def render(renderer):
                return renderer.render(view.camera, ["phong"], settings)["phong"].image

            self._renders[name] = encode_image("view.png", self.review.renders.call(render))
        return self._renders[name]

    def pick(self, name: str, x: float, y: float) -> dict:
        view = self.view(name)
        hit = self.review.picker().world_point(view.camera, x, y)
        return {"instance": None, "world": None} if hit is None else {"instance": hit[1], "world": hit[0].tolist()}

    # -- solve and save ------------------------------------------------------------------
    def solve(
        self, photo_ref: str, intrinsics_ref: str, view_name: str, photo_pixels, cad_pixels, snap: bool = True
    ) -> tuple[str, Solved]:
        """Solve the clicks (:func:`.clicks.solve_clicks`), render the overlay; (id, Solved)."""
        photo, image, camera = self.photo_and_camera(photo_ref, intrinsics_ref)
        view = self.view(view_name)
        cad = cad_points(self.review.picker(), view.camera, cad_pixels)
        snapper = self._snapper(image) if snap else None
        result = solve_clicks(photo.resolve(), image.shape[:2], camera, photo_pixels, cad, snapper)
        overlay = self.review.renders.call(lambda renderer: _overlay(renderer, result.camera, image))
        solved = Solved(result, photo_ref, photo, self.photo_name(photo_ref), encode_image("overlay.png", overlay))
        ident = secrets.token_hex(8)
        with self._lock:
            self._solved[ident] = solved
            while len(self._solved) > MAX_KEPT:
                self._solved.popitem(last=False)
        return ident, solved

    def _snapper(self, image: np.ndarray):
        scene = self.review.source.loaded
        if self._edges is None:
            self._edges = scene_edges(scene)
        # the photo in colour: the outline term of curved parts compares colour regions
        # (mrcheck.mr.edges.region); refine_pose makes the grey image of the edges itself
        photo = np.ascontiguousarray(image[..., :3])

        def snap(rough: Camera):
            return self.review.renders.call(
                lambda renderer: refine_pose(
                    scene, rough, photo, options=EdgeOptions(), renderer=renderer, edges=self._edges
                )
            )

        return snap

    def solved(self, ident: str) -> Solved:
        if not _ID.fullmatch(str(ident)) or ident not in self._solved:
            raise MrcheckError(f"no solve {ident!r} (solve the clicks again)")
        return self._solved[ident]

    def save(self, ident: str) -> Shot:
        """Write the solve's SHOT.json (and the uploaded photo beside it) under free names and
        add the shot to the review; a solve is saved once."""
        with self._lock:
            solved = self.solved(ident)
            source, folder = self.review.source, self.folder
            folder.mkdir(parents=True, exist_ok=True)
            photo, copied = solved.photo, None
            if solved.photo_ref.startswith("upload:"):
                if not solved.photo.is_file():  # forgotten: more than MAX_KEPT uploads since
                    raise MrcheckError(f"the uploaded photo {solved.photo_name} is no longer kept: upload it again")
                copied = photo = _copy_new(solved.photo, folder, solved.photo_name)
            try:
                name, shot_file = _free_shot(folder, shot_name(Path(photo).stem), source.shots)
                shot = solved.solve.shot.with_photo(photo)
                write_shot(shot_file, shot)
            except BaseException:
                if copied is not None:
                    copied.unlink(missing_ok=True)
                raise
            added = Shot(name, shot.camera, shot.photo, shot.rms)
            source.shots[name] = added
            source.files.append(shot_file)
            self._solved.pop(ident, None)
            return added

    def stage_frame(self, image: np.ndarray, camera: Camera) -> dict:
        """A frame frozen in the live check, to start Live from clicks: the frame (PNG) and the
        intrinsics it was taken with (camera JSON, no pose), staged as "Add photo" uploads;
        ``{"photo": {"ref", "name"}, "intrinsics": {"ref", "name"}}``."""
        import json

        photo = self.upload("photo", "live-frame.png", encode_image(".png", image))
        intrinsics = self.upload("intrinsics", "live-camera.json", json.dumps(camera.to_dict(pose=False)).encode())
        return {"photo": photo, "intrinsics": intrinsics}

    def save_frame(self, stem: str, image: np.ndarray, camera: Camera, report: dict) -> Shot:
        """A frame frozen in the live check as a new shot: ``image`` (RGB, ``camera``'s size) as a
        PNG and its SHOT.json at the tracked pose, under free names in the folder shots are added
        to, and in the review (report, CSV and BCF take it as any other shot)."""
        from mrcheck.core.output import write_image
        from mrcheck.core.shot import Shot as ShotRecord

        with self._lock:
            folder, source = self.folder, self.review.source
            folder.mkdir(parents=True, exist_ok=True)
            name, shot_file = _free_shot(folder, shot_name(stem), source.shots)
            _, photo = _free(folder, name, ".png")
            write_image(photo, image)
            try:
                write_shot(shot_file, ShotRecord(camera, photo, report))
            except BaseException:
                photo.unlink(missing_ok=True)
                raise
            added = Shot(name, camera, photo, None, shot_file)
            source.shots[name] = added
            source.files.append(shot_file)
            return added


def _overlay(renderer, camera: Camera, photo: np.ndarray) -> np.ndarray:
    """The CAD at ``camera`` over ``photo`` (at most :data:`SERVED_WIDTH` wide), edges on top."""
    import cv2

    if camera.width > SERVED_WIDTH:
        size = (SERVED_WIDTH, max(1, round(SERVED_WIDTH * camera.height / camera.width)))
        camera, photo = camera.resized(*size), cv2.resize(photo, size, interpolation=cv2.INTER_AREA)
    maps = distortion_map(camera)
    render_camera, offset = padded_camera(camera, maps)
    results = renderer.render(render_camera, ["phong"], RenderSettings(samples=4, seed=0).validated(camera.height))
    mixed = overlay_images(photo, {"phong": results["phong"].image}, camera, PHOTO_ALPHA, offset=offset, maps=maps)
    # the CAD's edges at part opacity: a fence's hundreds of edges would hide the photo they are judged on
    edges = distort_to_photo(
        cad_edges(results.depth, render_camera.fx).astype(np.float32), maps, offset, photo.shape[:2]
    )
    return draw_edges(mixed["phong"], np.minimum(edges * 2.0, 1.0) * EDGE_OPACITY, DEFAULT_EDGE_COLOR)


def _free(folder: Path, stem: str, suffix: str, taken=()) -> tuple[str, Path]:
    """The first of ``stem``, ``stem-2``, ... whose file does not exist and is not ``taken``."""
    for n in range(1, 10000):
        candidate = stem if n == 1 else f"{stem}-{n}"
        path = folder / f"{candidate}{suffix}"
        if candidate not in taken and not path.exists():
            return candidate, path
    raise MrcheckError(f"no free file name for {stem}{suffix}", folder)


def _free_shot(folder: Path, stem: str, shots: dict) -> tuple[str, Path]:
    """(shot name, SHOT.json path): a new file whose name is no shot's of the review."""
    stem = stem[:120]
    return _free(folder, stem, ".json", taken=shots)


def _copy_new(staged: Path, folder: Path, name: str) -> Path:
    """Copy ``staged`` into ``folder`` as ``name`` or a free variant; exclusive create, never overwriting."""
    stem, suffix = Path(name).stem, Path(name).suffix.lower()
    data = staged.read_bytes()
    while True:
        _, path = _free(folder, shot_name(stem), suffix)
        try:
            with open(path, "xb") as handle:
                handle.write(data)
            return path
        except FileExistsError:  # taken since the check: the next free name
            continue


__all__ = ["AddPhoto", "View", "Solved", "cad_views", "added_folder", "overview_camera"]
