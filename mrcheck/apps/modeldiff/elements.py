"""The elements of a scene as the model diff compares them: one per part instance, keyed by its
instance id (an IFC element's GlobalId, a STEP assembly path, a manifest's ``id`` or ``NAME#i``).

The comparison needs no rendering and no new triangulation: an element is its part's local mesh
(already loaded, shared by the part's instances) and its float64 local -> world transform.
Two elements have the same geometry when their meshes agree vertex for vertex within the
tolerance and their transforms differ by a rigid motion only, or, for a shape whose exporter
baked its position into the mesh, when the meshes have the same faces and their world vertices
differ by a rigid motion; the motion says whether the element moved
(:mod:`mrcheck.apps.modeldiff.compare`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mrcheck.apps.bcf import ifc_global_id, info_label
from mrcheck.scene.model import Part, Scene


@dataclass(frozen=True)
class Element:
    """One instance of a part.

    Attributes
    ----------
    id : str
        The instance id (unique in a scene: the manifest refuses repeats, the IFC import uses
        GlobalIds, the STEP import numbers repeated assembly paths ``#2``, ``#3``, ...).
    part : Part
        Its mesh (``vertices`` centred on the mesh's bounding box, metres).
    matrix : (4, 4) float64
        Local -> world.
    label : str
        How a person reads it: name (IFC class, storey), else the id.
    global_id : str or None
        The IFC GlobalId, where the scene came from IFC.
    """

    id: str
    part: Part
    matrix: np.ndarray
    label: str
    global_id: str | None

    @property
    def centre(self) -> np.ndarray:
        """(3,) float64 world position of the centre of the mesh's bounding box."""
        lo, hi = self.part.local_bounds()
        return self.matrix[:3, :3] @ ((lo + hi) / 2.0) + self.matrix[:3, 3]

    def corners(self) -> np.ndarray:
        """(8, 3) float64 world corners of the mesh's bounding box."""
        lo, hi = self.part.local_bounds()
        local = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        return local @ self.matrix[:3, :3].T + self.matrix[:3, 3]

    def world_vertices(self) -> np.ndarray:
        """(n, 3) float64 world positions of the mesh's vertices."""
        return self.part.vertices.astype(np.float64) @ self.matrix[:3, :3].T + self.matrix[:3, 3]

    def size(self) -> np.ndarray:
        """(3,) float64 extent of its world axis-aligned bounding box, metres."""
        corners = self.corners()
        return corners.max(axis=0) - corners.min(axis=0)


def scene_elements(scene: Scene) -> dict[str, Element]:
    """Every instance of ``scene`` by id, in scene order."""
    out: dict[str, Element] = {}
    for part in scene.parts:
        for k, instance_id in enumerate(part.instance_ids):
            out[instance_id] = Element(
                instance_id,
                part,
                np.asarray(part.transforms[k], np.float64),
                info_label(instance_id, part.instance_info[k]),
                ifc_global_id(part, k),
            )
    return out


def same_mesh(a: Part, b: Part, tolerance_m: float) -> bool:
    """Whether two parts' local meshes are the same: as many vertices and faces, the same faces,
    every vertex within ``tolerance_m`` (an exporter writes an unchanged shape the same way;
    one re-triangulated differently counts as changed)."""
    if a is b:
        return True
    if not same_topology(a, b):
        return False
    return float(np.abs(a.vertices.astype(np.float64) - b.vertices.astype(np.float64)).max(initial=0.0)) <= tolerance_m


def same_topology(a: Part, b: Part) -> bool:
    """Whether two meshes have as many vertices and the same faces (their positions may differ:
    a shape whose coordinates an exporter baked into the mesh, moved)."""
    return a.vertices.shape == b.vertices.shape and np.array_equal(a.faces, b.faces)


__all__ = ["Element", "scene_elements", "same_mesh", "same_topology"]
