"""What the ``render`` and ``demo`` commands do, as plain functions (testable without click).

They print nothing: they return the paths they wrote (``demo`` also reports each as it is
written, through ``on_written``), report progress through a callback and warn through
:func:`warnings.warn` (:class:`MrcheckWarning`, which the CLI shows as ``warning: ...`` lines).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import load_camera
from mrcheck.core.errors import MrcheckError, MrcheckWarning
from mrcheck.core.output import (
    AO_SUFFIXES,
    IMAGE_SUFFIXES,
    check_not_inputs,
    check_output_dir,
    check_output_path,
    labelled_sheet,
    write_all_or_none,
    write_ao,
    write_image,
)
from mrcheck.core.resources import sample_scene_path, shipped_scene
from mrcheck.render.renderer import MODES, STUDY_LABELS, Renderer, RenderResult, RenderSettings
from mrcheck.scene.manifest import scene_files
from mrcheck.scene.model import load_scene

STUDY_ORDER = ("phong", "vector", "ssao")  # D1 | D2 | D3, as in the paper's figure 5


def file_camera(view, camera_path, width, height) -> Camera | None:
    """The camera of ``--camera`` (resized to ``--width``/``--height``), read before the scene
    loads so that a bad camera file fails at once; None for ``--view``, which needs the scene
    (``scene.camera(view, width, height)``)."""
    if (view is None) == (camera_path is None):
        raise MrcheckError("give exactly one of --view NAME or --camera CAM.json|CAM.yml")
    if view is not None:
        return None
    return load_camera(camera_path).fitted(width, height, camera_path)


def scene_and_camera(scene, units, view, camera_path, width, height):
    """(the loaded scene, the camera) of ``render`` and ``reference``: a camera file is read
    first (a bad one fails before a long scene load), then the scene (with the units warning),
    then a ``--view`` camera, which needs the scene."""
    camera = file_camera(view, camera_path, width, height)
    loaded = load_scene(scene, units=units, progress=True)
    warn_units(loaded)
    return loaded, camera or loaded.camera(view, width, height)


def warn_units(scene) -> None:
    """As ``scene info`` does: a manifest part without declared units is taken as authored, and a
    part in mm read as metres is 1000x too big; a render alone gave no hint of it. (A single mesh
    file without --units is the ordinary case and is not warned about.)"""
    if scene.source.suffix.lower() != ".toml":
        return
    missing = [p.name for p in scene.parts if p.units is None]
    if missing:
        warnings.warn(
            f"{scene.source}: {len(missing)} part(s) without declared units, coordinates taken as "
            f"authored (not metres): {', '.join(missing)}",
            MrcheckWarning,
            stacklevel=2,
        )


def warn_if_nothing_in_view(depth, view, camera_path, subject="camera", hint="a wrong pose, or units?") -> None:
    """A background-only image (a wrong pose, or a camera kilometres away after a unit mix-up) is
    otherwise written with exit 0 and looks like a render (render, reference; overlay with
    ``subject`` "shot"); discrepancies warns in its own report."""
    if not (depth > 0).any():
        source = camera_path if view is None else f"viewpoint {view!r}"
        warnings.warn(f"{source}: no CAD part is in view of this {subject} ({hint})", MrcheckWarning, stacklevel=2)


def _ao_paths(output_ao: Path, modes) -> dict:
    ao_modes = [m for m in modes if m != "phong"]
    if len(ao_modes) == 1:
        return {ao_modes[0]: output_ao}
    return {m: output_ao.with_name(f"{output_ao.stem}_{m}{output_ao.suffix}") for m in ao_modes}


def _rendered_ao(result: RenderResult) -> np.ndarray:
    """The AO of a result rendered with ``want_ao``."""
    if result.ao is None:
        raise ValueError(f"the {result.mode} result was rendered without its AO")
    return result.ao


def render_command(
    scene, view, camera_path, mode, width, height, units, output, output_ao, settings: dict
) -> list[Path]:
    """``mrcheck render``: every output written, or none; returns the paths written."""
    output = check_output_path(output, IMAGE_SUFFIXES)
    modes = list(STUDY_ORDER) if mode == "all" else [mode]
    ao_paths = {}
    if output_ao is not None:
        output_ao = check_output_path(output_ao, AO_SUFFIXES, "AO output")
        if mode == "phong":
            raise MrcheckError(
                f"--output-ao needs an AO mode ({', '.join(m for m in MODES if m != 'phong')} or all), not phong"
            )
        ao_paths = {m: check_output_path(p, AO_SUFFIXES, "AO output") for m, p in _ao_paths(output_ao, modes).items()}
        for path in ao_paths.values():
            if path.resolve() == output.resolve():  # one would overwrite the other
                raise MrcheckError("the image and an AO output are the same file", path)
    check_not_inputs([output, *ao_paths.values()], [("the scene", scene_files(scene)), ("--camera", camera_path)])
    render_settings = RenderSettings(**settings)
    render_settings.validated(None)  # option errors before a long scene load
    loaded, camera = scene_and_camera(scene, units, view, camera_path, width, height)
    render_settings.validated(camera.height)  # option errors before the GL context is made

    renderer = Renderer(loaded)
    try:
        results = renderer.render(camera, modes, render_settings, want_ao=output_ao is not None)
        warn_if_nothing_in_view(results.depth, view, camera_path)
    finally:
        renderer.release()
    if mode == "all":
        image = labelled_sheet([results[m].image for m in modes], [STUDY_LABELS[m] for m in modes])
    else:
        image = results[mode].image
    writes = [lambda m=m, path=path: write_ao(path, _rendered_ao(results[m])) for m, path in ao_paths.items()]
    return list(write_all_or_none([*writes, lambda: write_image(output, image)]))


def _unchanged(items: Iterable, desc: str, unit: str) -> Iterable:
    return items


def demo_command(
    outdir: Path,
    width=None,
    height=None,
    on_written: Callable[[Path], None] = lambda path: None,
    progress: Callable[..., Iterable] = _unchanged,
) -> list[Path]:
    """Render the embedded scenes from each of their viewpoints in D1, D2, D3: the sample cell
    as ``VIEW_MODE.png`` and the generator's shipped cell as ``cell_VIEW_MODE.png``. Each path
    goes to ``on_written`` as it is written; ``progress(views, desc=..., unit=...)`` wraps each
    scene's views (a tqdm bar in the CLI). Returns the paths written."""
    outdir = check_output_dir(Path(outdir).resolve())
    scenes = [("", sample_scene_path()), ("cell_", shipped_scene("cell"))]
    written = []

    def write(path, image):
        written.append(write_image(path, image))
        on_written(written[-1])

    for prefix, manifest in scenes:
        scene = load_scene(manifest, progress=True)
        renderer = Renderer(scene)
        try:
            for view in progress(sorted(scene.viewpoints), desc=f"rendering {scene.name}", unit="view"):
                # only the modes written: the comparison modes would cost three AO passes per view
                results = renderer.render(scene.camera(view, width, height), STUDY_ORDER)
                for m in STUDY_ORDER:
                    write(outdir / f"{prefix}{view}_{m}.png", results[m].image)
                sheet = labelled_sheet([results[m].image for m in STUDY_ORDER], [STUDY_LABELS[m] for m in STUDY_ORDER])
                write(outdir / f"{prefix}{view}_study.png", sheet)
        finally:
            renderer.release()
    return written


__all__ = ["render_command", "demo_command", "file_camera", "scene_and_camera", "warn_units", "warn_if_nothing_in_view"]
