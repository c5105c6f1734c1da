"""A marker's offset in metres: where the photo shows a thing (the marker's pixel) against where
the CAD plans it (a second pixel, on the CAD part that should be there), issue 42's "how far is
this column from where it is planned".

One photo fixes the offset across the line of sight, not along it: the photo's point is taken at
the CAD point's depth (the plane through the CAD point square to the camera's optical axis). A
column 40 cm to the side of its planned place is measured as 40 cm; one 40 cm farther away
along the view is not seen as moved. The stored record keeps both world points and the pixel
of the CAD point, so a moved marker is measured again from the same CAD point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mrcheck.core.camera import Camera

DIGITS = 4  # 0.1 mm: far below what a photo pixel resolves at hall distances


@dataclass(frozen=True)
class PhotoOffset:
    """The offset of a marker's photo point from its CAD point, both in world metres."""

    cad_x: float  # the CAD point's pixel in the shot's photo (native pixels, like the marker's)
    cad_y: float
    cad_point: np.ndarray  # (3,) the CAD surface point at (cad_x, cad_y)
    photo_point: np.ndarray  # (3,) the marker's ray at the CAD point's depth
    part: str | None  # the part instance the CAD point lies on

    @property
    def offset(self) -> np.ndarray:
        """Photo minus CAD: where the thing is, from where it is planned (world axes, metres)."""
        return self.photo_point - self.cad_point

    def to_dict(self) -> dict:
        """The record the marker store keeps (JSON) and the API answers."""
        offset = self.offset
        return {
            "cad_x": round(float(self.cad_x), 2),
            "cad_y": round(float(self.cad_y), 2),
            "cad_point": _rounded(self.cad_point),
            "photo_point": _rounded(self.photo_point),
            "offset_m": _rounded(offset),
            "distance_m": round(float(np.linalg.norm(offset)), DIGITS),
            # the world's z is up in mrcheck's scenes: a planner reads "sideways" and "height" apart
            "horizontal_m": round(float(np.linalg.norm(offset[:2])), DIGITS),
            "vertical_m": round(float(offset[2]), DIGITS),
            "part": self.part,
        }


def _rounded(point: np.ndarray) -> list[float]:
    return [round(float(c), DIGITS) for c in point]


def photo_offset(picker, camera: Camera, marker_xy, cad_xy) -> PhotoOffset:
    """The offset of the thing at photo pixel ``marker_xy`` from the CAD point at pixel ``cad_xy``
    (both pixels of ``camera``'s photo, lens included); ValueError when no CAD lies under
    ``cad_xy``. ``picker``: the review's :class:`~mrcheck.apps.review.pick.Picker`."""
    hit = picker.world_point(camera, *cad_xy)
    if hit is None:
        raise ValueError(
            f"no CAD part under ({cad_xy[0]:.0f}, {cad_xy[1]:.0f}): click on the part that should be there"
        )
    cad_point, part = hit
    direction = picker.ray(camera, *marker_xy)
    axis = camera.R[2]  # the optical axis in world coordinates (the camera's +z)
    depth = float((cad_point - camera.center) @ axis)
    photo_point = camera.center + direction * (depth / float(direction @ axis))
    return PhotoOffset(float(cad_xy[0]), float(cad_xy[1]), cad_point, photo_point, part)


def offset_line(offset: dict) -> str:
    """The offset as one line of text (the report, the CSV's note, BCF's description)."""
    dx, dy, dz = offset["offset_m"]
    return (
        f"offset {offset['distance_m']:.3f} m from the planned position "
        f"(x {dx:+.3f}, y {dy:+.3f}, z {dz:+.3f} m; across the line of sight)"
    )


__all__ = ["PhotoOffset", "photo_offset", "offset_line"]
