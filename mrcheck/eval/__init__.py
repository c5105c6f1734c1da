"""Judging the rendering: ray-traced reference, compare, metrics, bench.

* ``raycast`` -- :class:`~mrcheck.eval.raycast.SceneCaster` (``build_caster``): ray casts and
  closest points against every part instance of a scene, float32-safe far from the origin; the
  one ray caster of mrcheck (the reference, the discrepancy check, the deviation, the review's
  picker);
* ``reference`` -- ``reference_ao``: the ray-traced AO the screen-space modes are judged
  against, and ``reference_command`` (``mrcheck reference``);
* ``metrics`` -- MAE, RMSE, SSIM, false occlusion, distance retention over covered pixels;
* ``compare`` -- ``compare_command`` (``mrcheck compare``): every AO mode against its reference;
* ``bench/`` -- ``mrcheck bench``: timings on this machine and against peer renderers.
"""
