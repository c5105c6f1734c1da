"""A glTF model (``.glb``, ``.gltf``) as elements: one per scene node that draws a mesh.

``mrcheck.scene.model.load_scene`` reads a glTF file as one mesh (everything merged), which is
what rendering needs; the diff needs the nodes. Here every mesh is a part, every node that
draws it an instance, at the node's world transform (glTF units are metres).

An element's id is its node path: the node names from the root down, joined by ``/``
(``line-1/robot/base``). glTF allows repeated node names; trimesh, which reads the file, keeps
the first and numbers the repeats ``NAME_1``, ``NAME_2`` in file order, so an element keeps its
id across revisions as long as the exporter keeps the order of same-named siblings (the same
rule as the STEP import's ``#2``). A path that still repeats (two nodes of one name under
parents that also repeat) gets ``#2``, ``#3``, ... in sorted order.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.scene.model import Scene, make_part

GLTF_SUFFIXES = (".glb", ".gltf")


def _node_path(graph, node: str) -> str:
    names, parents = [], graph.transforms.parents
    while node in parents:  # the root (base frame) has no parent and is not named
        names.append(node)
        node = parents[node]
    return "/".join(reversed(names))


def glb_scene(path: Path) -> Scene:
    """The elements of a glTF file as a scene (module docstring); MrcheckError when unreadable
    or without a mesh."""
    import trimesh

    try:
        with open(path, "rb") as handle:
            loaded = trimesh.load(
                handle,
                file_type=path.suffix.lower().lstrip("."),
                force="scene",
                resolver=trimesh.resolvers.FilePathResolver(str(path)),
            )
    except OSError as exc:
        raise MrcheckError(f"cannot read: {exc.strerror or exc}", path) from None
    except Exception as exc:  # trimesh raises many types for a corrupt file
        raise MrcheckError(f"not a readable glTF file ({type(exc).__name__}: {exc})", path) from None
    graph = loaded.graph
    by_mesh: dict[str, list] = {}
    used: dict[str, int] = {}
    for path_id, node in sorted((_node_path(graph, n), n) for n in graph.nodes_geometry):
        matrix, mesh_name = graph[node]
        count = used.get(path_id, 0)
        used[path_id] = count + 1
        by_mesh.setdefault(mesh_name, []).append((path_id if count == 0 else f"{path_id}#{count + 1}", matrix))
    parts = []
    for mesh_name, instances in by_mesh.items():
        mesh = loaded.geometry[mesh_name]
        if not hasattr(mesh, "faces") or len(mesh.faces) == 0:
            continue  # points or lines: nothing to compare or draw
        transforms = np.array([m for _, m in instances], np.float64)
        vertices, faces = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces)
        parts.append(
            make_part(mesh_name, path, vertices, faces, transforms, units="m", instance_ids=[i for i, _ in instances])
        )
    if not parts:
        raise MrcheckError("the glTF file has no triangle mesh", path)
    return Scene(name=path.stem, source=path, parts=parts)


__all__ = ["glb_scene", "GLTF_SUFFIXES"]
