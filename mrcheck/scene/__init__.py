"""The scene: what is planned, read from files. Imports only :mod:`mrcheck.core`.

Public API, by module:

* ``model``: :class:`Scene`, :class:`Part`, :func:`load_scene` (a manifest, one mesh file, or an
  IFC/STEP model through the import cache), :func:`make_part`;
* ``part_tables``: a ``[[parts]]`` table's values checked: :data:`UNITS`, :func:`unit_scale`,
  :func:`transform_from_table`, colour, joints;
* ``meshes``: :func:`read_mesh` (a CAD export or a posed URDF), :func:`validate_mesh`,
  :data:`MESH_SUFFIXES`;
* ``manifest``: :func:`read_manifest`, :func:`dumps_manifest`, :func:`scene_files` (every file a
  scene loads), :func:`files_stamp`, :func:`write_generated` (a generated folder, atomically);
* ``info``: :func:`describe`, :func:`format_info` (``mrcheck scene info``);
* ``robots``: the shipped URDF robots (:func:`robot_urdf`, :func:`copy_robot`, pose sampling);
* ``asbuilt``: :func:`make_asbuilt` (``mrcheck scene asbuilt``); ``asbuilt_plan``: how its
  changes are chosen;
* ``elements``: :class:`ElementInfo` (an imported element's name, IFC class, storey:
  ``Part.instance_info``), the manifest's float64 ``origin`` (``Scene.origin``, ``Scene.crs``),
  instances files;
* ``packages``: URDF ``package://`` resolution (:func:`set_package_path`, :func:`resolve`);
* ``raycast``: :class:`SceneCaster` (:func:`build_caster`): ray casts and closest points against
  every part instance of a scene (Open3D), float32-safe far from the origin; the one ray caster
  of mrcheck (the reference AO, the discrepancy check, the deviation, the review's picker);
* ``importers``: IFC and STEP (:func:`read_model`), ``importers.cache``: :func:`import_scene`
  (``mrcheck scene import``), :func:`cached_manifest` (what ``load_scene`` reads a model file
  given as SCENE through).

The scene generator (``factory_scenes``) builds on this API; mrcheck never imports it below the
command line.
"""
