"""A view rendered for a regression test: its image in every mode and its id buffer.

The images come from :class:`mrcheck.render.renderer.Renderer` (one G-buffer per view, every
mode from it). The id buffer is the discrepancy check's ray cast
(:func:`mrcheck.apps.discrepancies.ids.object_ids`): per pixel the part instance seen and its
depth, exactly in the render's pixel grid, with no change to the renderer.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from mrcheck.apps.discrepancies.ids import object_ids
from mrcheck.apps.regress.baseline import IdBuffer
from mrcheck.core.camera import Camera
from mrcheck.core.progress import Progress, no_progress
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.model import Scene


@dataclass(frozen=True)
class Snapshot:
    """One view rendered: ``images`` mode -> (H, W, 3) uint8 sRGB, and its id buffer."""

    name: str
    camera: Camera
    images: dict[str, np.ndarray]
    ids: IdBuffer
    gl_renderer: str = ""  # the GL renderer that drew it (a worker's, on a cluster)


def element_labels(scene: Scene, labels) -> np.ndarray:
    """(N, 4) str: part, instance id, element name, IFC class of each ``(part, instance)`` label."""
    info = {(p.name, iid): i for p in scene.parts for iid, i in zip(p.instance_ids, p.instance_info)}
    rows = [(part, iid, info[part, iid].name, info[part, iid].ifc_class) for part, iid in labels]
    return np.array(rows, dtype=str).reshape(len(rows), 4)


def id_buffer(scene: Scene, camera: Camera) -> IdBuffer:
    # the renderer draws the ideal pinhole image of K (a SHOT.json's lens distortion is not
    # applied to a render): the ids are cast through the same pixels, without the distortion
    pinhole = dataclasses.replace(camera, dist=np.zeros(0))
    ids, depth, labels = object_ids(scene, pinhole)
    return IdBuffer(ids, depth, element_labels(scene, labels))


class SnapshotRenderer:
    """Renders views of one scene in ``modes`` (one GL context for them all); use as a context
    manager. ``gl_renderer``: the GL renderer's name (llvmpipe, a GPU's), for the manifest."""

    def __init__(self, scene: Scene, modes, settings: RenderSettings):
        self.scene, self.modes, self.settings = scene, list(modes), settings
        self.renderer = Renderer(scene)
        self.gl_renderer = str(self.renderer.ctx.info["GL_RENDERER"])

    def render(self, name: str, camera: Camera) -> Snapshot:
        frame = self.renderer.render(camera, self.modes, self.settings)
        images = {m: frame[m].image for m in self.modes}
        return Snapshot(name, camera, images, id_buffer(self.scene, camera), self.gl_renderer)

    def render_all(self, views: list[tuple[str, Camera]], progress: Progress = no_progress) -> Iterator[Snapshot]:
        """Each view in turn (a report may hold many views: their images are not all kept)."""
        with contextlib.closing(progress(views, "rendering views", "view")) as shown:
            for name, camera in shown:
                yield self.render(name, camera)

    def __enter__(self) -> SnapshotRenderer:
        return self

    def __exit__(self, *exc) -> None:
        self.renderer.release()


__all__ = ["Snapshot", "SnapshotRenderer", "id_buffer", "element_labels"]
