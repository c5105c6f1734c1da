"""An IFC file's length unit: what it declares, what ``scene import --units`` says instead, and
a warning when its elements' sizes are implausible for the unit it is read in.

IfcOpenShell reads a file without an IfcUnitAssignment as metres, and an exporter that writes
millimetre numbers without declaring them makes a 4 m wall 4,000 m long. Building elements are
centimetres to tens of metres: when the median element's largest dimension is outside
:data:`PLAUSIBLE_M`, the import warns and names the ``--units`` value that brings it closest to
:data:`TYPICAL_M`.
"""

from __future__ import annotations

import numpy as np

# metres per unit, the values --units takes (as mrcheck.scene.model.UNITS for mesh files)
LENGTH_UNITS = {"mm": 0.001, "cm": 0.01, "m": 1.0, "in": 0.0254, "ft": 0.3048}
PLAUSIBLE_M = (0.01, 200.0)  # a median element's largest dimension, metres
TYPICAL_M = 2.0


def declared_unit(model) -> tuple[str, float] | None:
    """(name, metres per unit) of the file's declared length unit, None when it declares none."""
    import ifcopenshell.util.unit

    unit = ifcopenshell.util.unit.get_project_unit(model, "LENGTHUNIT")
    if unit is None:
        return None
    name = (getattr(unit, "Prefix", None) or "").lower() + str(getattr(unit, "Name", "") or "").lower()
    return name or "the declared unit", float(ifcopenshell.util.unit.calculate_unit_scale(model))


def median_size(parts) -> float:
    """The median over elements of the largest dimension of each element's shape (metres)."""
    sizes = [float(np.ptp(p.vertices, axis=0).max()) for p in parts for _ in p.instances if len(p.vertices)]
    return float(np.median(sizes)) if sizes else 0.0


def rescale(parts, origin: np.ndarray | None, factor: float) -> None:
    """Scale the parts' triangles and the instances' translations (and ``origin``) in place:
    the file's numbers read in another unit."""
    for part in parts:
        part.vertices = part.vertices * factor
        for instance in part.instances:
            instance.matrix = instance.matrix.copy()
            instance.matrix[:3, 3] *= factor
    if origin is not None:
        origin *= factor


def unit_note(model, parts, units: str | None) -> str | None:
    """The warning for element sizes implausible in the unit the file is read in, else None."""
    size = median_size(parts)
    if size == 0.0 or PLAUSIBLE_M[0] <= size <= PLAUSIBLE_M[1]:
        return None
    declared = declared_unit(model)
    read_m = LENGTH_UNITS[units] if units else declared[1] if declared else 1.0
    raw = size / read_m  # the median size in the file's own numbers
    best = min(LENGTH_UNITS, key=lambda u: abs(np.log(raw * LENGTH_UNITS[u] / TYPICAL_M)))
    how = (
        f"read as {units} (--units)"
        if units
        else f"declared as {declared[0]}"
        if declared
        else "no length unit declared: read as metres"
    )
    return (
        f"elements are implausibly {'large' if size > PLAUSIBLE_M[1] else 'small'} (median {size:,.3g} m; {how}); "
        f"if the coordinates are in {best}, import with `mrcheck scene import FILE --units {best} -o DIR`"
    )


__all__ = ["LENGTH_UNITS", "PLAUSIBLE_M", "declared_unit", "median_size", "rescale", "unit_note"]
