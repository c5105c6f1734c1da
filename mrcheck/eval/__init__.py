"""Judging the rendering and the apps: ray-traced reference, compare, metrics, benches, harnesses.

This layer sits above :mod:`mrcheck.apps` (it judges them) and below the command line.

* ``reference`` -- ``reference_ao``: the ray-traced AO the screen-space modes are judged
  against, and ``reference_command`` (``mrcheck reference``);
* ``metrics`` -- MAE, RMSE, SSIM, false occlusion, distance retention over covered pixels;
* ``compare`` -- ``compare_command`` (``mrcheck compare``): every AO mode against its reference;
* ``bench/`` -- ``mrcheck bench``: timings on this machine and against peer renderers;
* ``edgebench``, ``trackbench`` -- ``bench --edges`` and ``bench --track`` (test photos from
  ``edgephotos`` and ``edgescenes``, walk videos from ``walks``);
* ``discrepancy_eval`` -- :func:`evaluate`: the discrepancy check's precision and recall on
  as-built variants; ``deviation_eval`` -- :func:`score_seed`: the deviation's element statuses
  on simulated scans (``scansim``) of shifted variants.
"""
