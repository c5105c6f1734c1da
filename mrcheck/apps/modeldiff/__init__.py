"""``mrcheck regress diff``: two revisions of a model, element by element and in pictures.

* ``elements`` -- :class:`Element`: a part instance as the diff compares it (id, mesh, transform);
* ``compare`` -- :func:`diff_scenes`: added, removed, moved (offset, rotation), changed geometry,
  unchanged (:class:`ModelDiff` of :class:`Change` rows), no rendering needed;
* ``glb`` -- :func:`glb_scene`: a glTF file node by node (ids: node paths); ``revisions`` --
  :func:`load_revisions`: OLD and NEW, glTF through ``glb``, anything else as a scene;
* ``picture`` -- :func:`diff_picture`: a view of both revisions over the vector-AO render, the
  changes tinted and the moves drawn as arrows;
* ``report`` -- ``changes.csv``, ``changes.json`` and the BCF topics of the changes;
* ``command`` -- :func:`diff_command`: load, compare, draw, write everything or nothing.
"""

from mrcheck.apps.modeldiff.compare import KINDS, TOLERANCE_DEG, TOLERANCE_M, Change, ModelDiff, diff_scenes
from mrcheck.apps.modeldiff.elements import Element, scene_elements

__all__ = ["Change", "ModelDiff", "diff_scenes", "Element", "scene_elements", "KINDS", "TOLERANCE_M", "TOLERANCE_DEG"]
