"""Where an IFC model sits on the map: IfcMapConversion, or its site's placement.

IFC4's IfcMapConversion takes the project's engineering coordinates to a projected CRS
(``IfcProjectedCRS``, e.g. EPSG:25832, UTM zone 32N)::

    map_xy = (Eastings, Northings) + Scale * R(theta) @ xy      theta from (XAxisAbscissa, XAxisOrdinate)
    map_z  = OrthogonalHeight + Scale * z

The scene keeps the offset as its float64 ``origin`` and every placement relative to it, so a
factory at 5e6 m stays exact to well below a millimetre (float64 steps 1e-9 m there).
Coordinates here are metres (IfcOpenShell converts the model; the offsets are converted from
the CRS's map unit, or the project's length unit when the CRS names none).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mrcheck.core.errors import MrcheckError


@dataclass
class Placement:
    """The import's world frame: ``matrix`` maps IfcOpenShell's coordinates (metres) to the
    scene's, relative to ``origin`` (float64, metres)."""

    matrix: np.ndarray
    origin: np.ndarray
    crs: str = ""
    notes: list = field(default_factory=list)
    on_map: bool = False  # origin in map units (IfcMapConversion), not the file's length unit

    """Metres per unit of an IfcNamedUnit (SI with prefix, or a conversion-based unit)."""


def _si_scale(unit) -> float:
    prefixes = {"MILLI": 1e-3, "CENTI": 1e-2, "DECI": 1e-1, "KILO": 1e3, None: 1.0}
    if unit.is_a("IfcSIUnit"):
        return prefixes.get(unit.Prefix, 1.0)
    if unit.is_a("IfcConversionBasedUnit"):
        factor = unit.ConversionFactor
        return float(factor.ValueComponent.wrappedValue) * _si_scale(factor.UnitComponent)
    return 1.0


def map_conversion(model, path=None) -> Placement | None:
    """The Placement of the model's first IfcMapConversion (None when it has none: IFC2X3
    files, and most IFC4 exports). Raises MrcheckError naming ``path`` for a Scale that is 0,
    negative or not finite (a zero matrix would put every element at the map origin) and an
    offset that is not finite."""
    conversions = model.by_type("IfcMapConversion") if model.schema != "IFC2X3" else []
    if not conversions:
        return None
    conv = conversions[0]
    crs = conv.TargetCRS
    unit_m = _map_unit_m(model, crs)
    scale = float(conv.Scale) if conv.Scale is not None else 1.0
    if not (np.isfinite(scale) and scale > 0.0):
        raise MrcheckError(f"the IfcMapConversion #{conv.id()} has Scale {scale!r}: it must be positive", path)
    abscissa = float(conv.XAxisAbscissa) if conv.XAxisAbscissa is not None else 1.0
    ordinate = float(conv.XAxisOrdinate) if conv.XAxisOrdinate is not None else 0.0
    theta = np.arctan2(ordinate, abscissa)
    matrix = np.eye(4)
    c, s = np.cos(theta), np.sin(theta)
    matrix[:2, :2] = scale * np.array([[c, -s], [s, c]])
    matrix[2, 2] = scale
    origin = np.array([float(conv.Eastings), float(conv.Northings), float(conv.OrthogonalHeight or 0.0)]) * unit_m
    if not np.isfinite(origin).all():
        raise MrcheckError(f"the IfcMapConversion #{conv.id()} has an offset that is not finite", path)
    name = str(getattr(crs, "Name", "") or "") if crs is not None else ""
    return Placement(matrix=matrix, origin=origin, crs=name, on_map=True)


def _map_unit_m(model, crs) -> float:
    unit = getattr(crs, "MapUnit", None) if crs is not None else None
    if unit is None:
        import ifcopenshell.util.unit

        return float(ifcopenshell.util.unit.calculate_unit_scale(model))
    return _si_scale(unit)


def site_origin(model) -> Placement:
    """The model's own coordinates, relative to the translation of its (first) site's placement:
    files without a map conversion often put their survey coordinates there."""
    import ifcopenshell.util.placement
    import ifcopenshell.util.unit

    origin = np.zeros(3)
    sites = model.by_type("IfcSite")
    if sites and sites[0].ObjectPlacement is not None:
        local = np.asarray(ifcopenshell.util.placement.get_local_placement(sites[0].ObjectPlacement), np.float64)
        origin = local[:3, 3] * float(ifcopenshell.util.unit.calculate_unit_scale(model))
    matrix = np.eye(4)
    matrix[:3, 3] = -origin
    return Placement(matrix=matrix, origin=origin)


__all__ = ["Placement", "map_conversion", "site_origin"]
