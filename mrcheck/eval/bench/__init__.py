"""``mrcheck bench``: timings of every pass, the peers (VTK, Open3D).

Public API: :func:`mrcheck.eval.bench.run.bench_command` (returns a ``BenchResult``: the report,
the text to print, the JSON written) with the hall generator (``scenes.HallGenerator``) and a
progress callback given by the command line. The modules: ``figures`` (settings, the paper's
figures, the targets, ``Figure``), ``scenes``, ``timing`` (``Stage``, ``measure``), ``plan``,
``line`` (the line scene and the peers' stages), ``report`` (ratios, table, text), ``peers``
(the peers' worker process) and ``peer_client`` (the bench's side of it).
"""
