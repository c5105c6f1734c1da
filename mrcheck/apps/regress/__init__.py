"""Image regression tests of a scene's agreed views (issue 43): ``mrcheck regress record`` and
``mrcheck regress check``, and the pytest plugin that runs the same comparison.

Public API: :func:`mrcheck.apps.regress.run.record` (render views, write a baseline),
:func:`mrcheck.apps.regress.run.check` (render again, compare with FLIP, attribute the changed
pixels to elements, write the report), the records :class:`~mrcheck.apps.regress.baseline.Baseline`,
:class:`~mrcheck.apps.regress.compare.Tolerances`, :class:`~mrcheck.apps.regress.run.CheckResult`;
the pytest plugin :mod:`mrcheck.apps.regress.pytest_plugin` (entry point ``pytest11``).

Modules: ``baseline`` (baseline.json and the files beside it: the one reader and writer),
``views`` (which views: viewpoints, camera files, SHOT.json), ``snapshots`` (a view rendered in
its modes, with its id buffer), ``compare`` (FLIP and the tolerances), ``attribution`` (which
elements lie under the changed pixels), ``report`` (HTML and JUnit XML), ``workers`` (many views
on the export's local workers or a Dask cluster), ``run`` (the commands).
"""
