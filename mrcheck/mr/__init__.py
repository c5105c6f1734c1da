"""Mixed reality: the photo's camera and the CAD over the photo. Imports core, scene, render.

Public API, by module:

* ``boards``: :func:`parse_board`, :class:`Board` (calibration boards found in a photo);
* ``calibration``: :func:`calibrate`, :func:`calibrate_command` (``mrcheck calibrate``);
* ``markers``: :func:`load_marker_map`, :func:`detect_markers` (ArUco, AprilTag, ChArUco);
* ``pose``: :func:`solve_pose` (robust PnP), :func:`expected_overlay_error`;
* ``registration``: :func:`register_photo` (markers or points), :func:`load_points`;
* ``edgeshot``: :func:`snap_photo` (the CAD snapped onto the photo's edges), :func:`view_camera`;
* ``register``: :func:`register_command` (``mrcheck register``: a start, then optional edges),
  :class:`RegistrationResult`;
* ``lens``: :func:`distortion_map`, :func:`padded_camera`, :func:`distort_to_photo`;
* ``overlay``: blending only: :func:`overlay_images`, :func:`blend`, :func:`study_sheet`;
* ``shot``: :func:`render_for_photo`, :func:`cad_edges`, :func:`overlay_shot` (``mrcheck overlay``).
"""
