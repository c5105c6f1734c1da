"""Foundations every layer uses; imports nothing of mrcheck above it.

Public API, by module:

* ``errors``: :class:`MrcheckError` (the one-line ``error: ...``), :class:`MrcheckWarning` and
  :func:`warn` (shown by the CLI as ``warning: ...``), :func:`display` (printable file names);
* ``camera``: :class:`Camera` (the pinhole model, no file I/O), :func:`gl_projection`, :func:`fit_size`;
* ``camerafiles``: every camera and shot file: :func:`load_camera` (a camera to render from),
  :func:`read_camera` (intrinsics), :func:`write_camera`, :func:`load_shot`, :func:`read_photo`;
* ``shot``: :class:`Shot` (a registered photo, SHOT.json), its one reader :func:`read_shot` and
  one writer :func:`write_shot` (:func:`shot_text`), :func:`photo_reference`;
* ``jsonfile``: :func:`read_json`; ``inputs``: :func:`check_input`, :func:`read_input`;
  ``images``: :func:`read_image`, :func:`encode_image`;
* ``output``: atomic writes (:func:`write_image`, :func:`write_text`, ...), output checks
  (:func:`check_output_path`, :func:`check_not_inputs`), :func:`labelled_sheet`;
* ``progress``: the :data:`Progress` callback long loops take, :func:`no_progress`;
* ``resources``: :func:`shader_dir`, :func:`shipped_scene`, :func:`sample_scene_path`,
  :func:`robot_assets_dir` (the one module that knows where ``factory_scenes`` keeps them);
  ``quiet``: :func:`native_output` (silencing C libraries).
"""
