"""Many views rendered through the export's machinery: in this process, in spawned local
workers (:func:`mrcheck.apps.export.execute.worker_pool`: each with its own EGL context and its
share of llvmpipe's threads) or on a Dask cluster (:func:`mrcheck.apps.export.execute.connect`),
whose workers load the scene themselves from its path.

A worker keeps its scene and renderer between the views it is given (loading the scene is most
of a small view's cost); the views come back as they finish and are put in order by the caller.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from concurrent.futures import as_completed
from dataclasses import dataclass

from mrcheck.apps.regress.snapshots import Snapshot, SnapshotRenderer
from mrcheck.core.camera import Camera
from mrcheck.core.progress import Progress, no_progress
from mrcheck.render.settings import RenderSettings
from mrcheck.scene.model import load_scene


@dataclass(frozen=True)
class ViewTask:
    """One view to render in a worker: the scene's path (the worker loads it) and what to render."""

    scene: str
    name: str
    camera: Camera
    modes: tuple[str, ...]
    settings: RenderSettings


_RENDERERS: dict[tuple, SnapshotRenderer] = {}  # per worker process: the last scene's renderer


def render_task(task: ViewTask) -> Snapshot:
    """A worker's view (the scene and renderer kept for the next task of the same scene)."""
    key = (task.scene, task.modes, task.settings)
    renderer = _RENDERERS.get(key)
    if renderer is None:
        for old in _RENDERERS.values():
            old.__exit__()
        _RENDERERS.clear()
        renderer = _RENDERERS[key] = SnapshotRenderer(load_scene(task.scene), task.modes, task.settings)
    return renderer.render(task.name, task.camera)


def render_views(
    scene,
    loaded,
    views: list[tuple[str, Camera]],
    modes,
    settings: RenderSettings,
    workers: int = 1,
    client=None,
    progress: Progress = no_progress,
) -> Iterator[Snapshot]:
    """Each view's :class:`Snapshot`, as it finishes: in this process on ``loaded`` (the scene
    already loaded) with one worker and no ``client``, else in ``workers`` local processes or on
    the Dask cluster of ``client``."""
    if client is None and (workers <= 1 or len(views) <= 1):
        with SnapshotRenderer(loaded, modes, settings) as renderer:
            yield from renderer.render_all(views, progress)
        return
    tasks = [ViewTask(str(scene), name, camera, tuple(modes), settings) for name, camera in views]
    finished = _on_cluster(tasks, client) if client is not None else _on_local_workers(tasks, workers)
    with contextlib.closing(progress(finished, "rendering views", "view")) as shown:
        yield from shown


def _on_local_workers(tasks: list[ViewTask], workers: int) -> Iterator[Snapshot]:
    from mrcheck.apps.export.execute import worker_pool

    # each worker keeps its scene between views (render_task): it loads it once
    with worker_pool(min(workers, len(tasks))) as pool:
        futures = [pool.submit(render_task, task) for task in tasks]
        for future in as_completed(futures):
            yield future.result()


def _on_cluster(tasks: list[ViewTask], client) -> Iterator[Snapshot]:
    from distributed import as_completed as dask_completed

    for future in dask_completed(client.map(render_task, tasks, pure=False)):
        yield future.result()
        future.release()


__all__ = ["ViewTask", "render_task", "render_views"]
