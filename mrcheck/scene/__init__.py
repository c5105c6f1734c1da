"""The scene: what is planned, read from files. Imports only :mod:`mrcheck.core`.

Public API, by module:

* ``model``: :class:`Scene`, :class:`Part`, :func:`load_scene` (a manifest or one mesh file),
  :func:`make_part`, :data:`UNITS`, :func:`transform_from_table`;
* ``meshes``: :func:`read_mesh` (a CAD export or a posed URDF), :func:`validate_mesh`,
  :data:`MESH_SUFFIXES`;
* ``manifest``: :func:`read_manifest`, :func:`dumps_manifest`, :func:`scene_files` (every file a
  scene loads), :func:`files_stamp`, :func:`write_generated` (a generated folder, atomically);
* ``info``: :func:`describe`, :func:`format_info` (``mrcheck scene info``);
* ``robots``: the shipped URDF robots (:func:`robot_urdf`, :func:`copy_robot`, pose sampling);
* ``asbuilt``: :func:`make_asbuilt` (``mrcheck scene asbuilt``); ``asbuilt_plan``: how its
  changes are chosen.

The scene generator (``factory_scenes``) builds on this API; mrcheck never imports it below the
command line.
"""
