"""Which elements lie under a view's changed pixels, from the id buffers of both renders; and
where the scene's geometry changed (:func:`geometry_changes`).

At a changed pixel that shows the same element in both renders, that element changed its look
(colour, shading). Where the two show different elements, the nearer of the two is the one that
moved, appeared or went: what lies behind it was only uncovered or hidden (a conveyor moved
over the floor: the conveyor is named, not the floor).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mrcheck.apps.regress.baseline import IdBuffer


@dataclass(frozen=True)
class ChangedElement:
    """An element under changed pixels: its part, instance id (an IFC GlobalId for imported
    scenes), element name and IFC class (empty when not imported), how many changed pixels, and
    how many of them show this element in one render and another element in the other
    (``moved``: it moved, appeared or went there)."""

    part: str
    instance: str
    name: str
    ifc_class: str
    pixels: int
    moved: int = 0

    @property
    def kind(self) -> str:
        return "moved, added or removed" if self.moved else "looks different"


def _keys(buffer: IdBuffer) -> np.ndarray:
    """Per pixel the (part, instance) key of its element, "" for the background."""
    labels = buffer.labels
    keys = np.array([f"{p}\x00{i}" for p, i in labels[:, :2]] + [""], dtype=object)
    return keys[np.where(buffer.ids >= 0, buffer.ids, len(labels))]


def attribute(changed: np.ndarray, before: IdBuffer, now: IdBuffer) -> list[ChangedElement]:
    """The elements under the ``changed`` (H, W) bool pixels, most pixels first."""
    if before.ids.shape != changed.shape or now.ids.shape != changed.shape:
        return []
    key_before, key_now = _keys(before)[changed], _keys(now)[changed]
    far = np.float32(np.inf)
    depth_before = np.where(before.depth[changed] > 0, before.depth[changed], far)
    depth_now = np.where(now.depth[changed] > 0, now.depth[changed], far)
    key = np.where(depth_now < depth_before, key_now, key_before)  # the nearer of the two
    differs = key_before != key_now
    seen = key != ""
    names, counts = np.unique(key[seen].astype(str), return_counts=True)
    moved_names, moved_counts = np.unique(key[seen & differs].astype(str), return_counts=True)
    moved = dict(zip(moved_names, moved_counts))
    info = {f"{row[0]}\x00{row[1]}": row for buffer in (before, now) for row in buffer.labels}
    found = [
        ChangedElement(*(str(v) for v in info[k]), pixels=int(n), moved=int(moved.get(k, 0)))
        for k, n in zip(names, counts)
    ]
    return sorted(found, key=lambda e: (not e.moved, -e.pixels, e.part, e.instance))


DEPTH_TOLERANCE_M = 1e-3  # a depth change below this is float32 rounding of the cast, not a move
DEPTH_TOLERANCE_REL = 1e-5  # ... and below this fraction of the depth (float32: 6e-8 relative)


def geometry_changes(before: IdBuffer, now: IdBuffer) -> np.ndarray:
    """(H, W) bool: the pixels whose ray cast hits another element (or none) now, or the same
    one more than 1 mm (and 1e-5 of the depth) nearer or farther. The id buffers are cast on the
    CPU (Open3D) through the pixel centres, not rasterised, so no GPU, driver or thread count
    changes them: they differ where the scene's geometry moved, appeared or went, by however
    little (a conveyor 2 cm off at 10 m moves its outline by a pixel, which FLIP's tolerance,
    sized for other rasterisers, lets pass)."""
    if before.ids.shape != now.ids.shape:
        return np.ones(now.ids.shape, bool)
    key_before, key_now = _keys(before), _keys(now)
    tolerance = np.maximum(DEPTH_TOLERANCE_M, DEPTH_TOLERANCE_REL * np.maximum(before.depth, now.depth))
    return (key_before != key_now) | (np.abs(before.depth - now.depth) > tolerance)


def element_label(element: ChangedElement) -> str:
    """``conveyor``, ``pallet#3`` or ``wall 2O2Fr$t4X7Zf8NOew3FLOH`` (part and GlobalId), with the
    element's name and class for imported scenes."""
    own = element.instance == element.part or element.instance.startswith(element.part + "#")
    text = element.instance if own else f"{element.part} {element.instance}"
    extra = " ".join(x for x in (element.name, element.ifc_class) if x)
    return f"{text} ({extra})" if extra else text


__all__ = ["ChangedElement", "attribute", "element_label", "geometry_changes"]
