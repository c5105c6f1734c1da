"""CAD and BIM importers: IFC (IfcOpenShell) and STEP (OpenCascade through cadquery-ocp).

Public API:

- :func:`read_model` (path, settings, progress) -> :class:`~.records.ImportedModel`: parse and
  tessellate an .ifc / .step / .stp file (its content checked against its extension first).
- :func:`mrcheck.scene.importers.cache.import_scene`: write a model as a normal mrcheck scene
  folder (manifest + GLB meshes), and :func:`~.cache.cached_manifest`: the same through the
  content-keyed cache, for commands given the model file itself.
- records: :class:`~.records.ImportSettings`, :class:`~.records.ImportedModel`,
  :class:`~.records.ImportedPart`, :class:`~.records.ImportedInstance`,
  :class:`~.records.FailedElement`, :class:`~.records.ImportResult`.
"""

from __future__ import annotations

from pathlib import Path

from mrcheck.core.errors import MrcheckError
from mrcheck.core.progress import Progress, no_progress
from mrcheck.scene.importers.records import ImportedModel, ImportSettings
from mrcheck.scene.importers.sniff import IMPORT_SUFFIXES, sniff


def read_model(path, settings: ImportSettings | None = None, progress: Progress = no_progress) -> ImportedModel:
    """The parts and instances of an IFC or STEP file; ``progress`` (a
    :data:`mrcheck.core.progress.Progress`) shows the shapes as they are built."""
    path = Path(path)
    settings = settings or ImportSettings()
    kind = sniff(path)
    if kind.kind == "ifc":
        from mrcheck.scene.importers.ifc import read_ifc

        return read_ifc(path, kind, settings, progress)
    if settings.units:
        raise MrcheckError("--units applies to an IFC file; a STEP file declares its own units", path)
    from mrcheck.scene.importers.step import read_step

    return read_step(path, kind, settings, progress)


__all__ = ["read_model", "ImportSettings", "ImportedModel", "IMPORT_SUFFIXES"]
