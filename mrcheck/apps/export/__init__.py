"""``mrcheck export``: batch registration, renders, overlays, sheets and a report for a whole job.

Job file (TOML; every relative path is relative to the job file's folder)::

    scene = "factory_scenes/sample_cell/scene.toml"   # required: the planned CAD (manifest or mesh)
    modes = ["phong", "vector", "ssao"]       # D1, D2, D3 by default; any of
    # phong vector ssao crytek hbao alchemy gtao vbao
    alphas = [0.0, 0.5, 1.0]                  # photo opacities of the overlays, 0..1 (default [0.5])
    intensities = [0.5, 1.0, 1.5, 2.0]        # AO strengths, weak to strong (default [1.0]; AO modes only)
    overlay_intensity = 1.0                   # optional: the intensity of the overlays and the sheet;
                                              # default 1.0 when listed, else the middle of `intensities`
    width = 640                               # optional: output width; the camera (K) and the photo are
                                              # scaled to it, same aspect ratio (default: the photo's size)
    max_registration_error_px = 2.0           # optional: a shot registered with a larger RMS fails
    samples = 16                              # optional: AO samples per pixel
    accumulate = 1                            # optional: AO frames averaged (progressive AO, 1..256)
    edges = false                             # optional: draw the CAD's edges over the overlays
    antialias = true                          # optional: anti-aliased renders (4x MSAA; about 1.3-1.5x the time)
    intrinsics = "camera.json"                # optional defaults for every [[shots]] entry below
    markers = "markers.json"

    [[shots]]                                 # an already registered SHOT.json (`mrcheck register`)
    name = "north-01"                         # optional (default: the file's stem)
    shot = "shots/north-01.json"

    [[shots]]                                 # one photo, registered here
    photo = "photos/south-07.jpg"
    intrinsics = "camera.json"                # camera JSON or OpenCV YAML (or the job-wide default)
    points = "south-07.corr.json"             # manual correspondences, or markers = "MAP.json"

    [[shots]]                                 # a glob of photos from one camera; each is a shot
    photos = "photos/hall-*.jpg"              # named after the file's stem
    markers = "markers.json"                  # (a glob takes markers only: points are per photo)

Shot names must be unique and use letters, digits, ``.``, ``_`` and ``-`` (names from a glob
are sanitised). A bad job (malformed TOML, unknown key, no scene or one that does not load, no
shots, an unknown mode, an alpha outside 0..1, a glob matching nothing, a missing intrinsics or
marker file) is a one-line ``error: JOB.toml: ...`` before anything is written.

Per shot, under ``OUTDIR/shots/NAME/`` (``{x:g}`` numbers: ``i1``, ``i0.5``, ``a0``):

* ``SHOT.json`` -- the registered shot (a copy when the job gives one), its photo path relative
  to this folder (:func:`mrcheck.core.shot.photo_reference`);
* ``render_phong.png`` and ``render_MODE_iI.png`` for every AO mode and every intensity: the CAD
  alone in the photo's geometry (lens distortion applied, the photo's size);
* ``overlay_MODE_aA.png`` for phong and ``overlay_MODE_iI_aA.png`` for every AO mode, every alpha,
  at the overlay intensity only (so the count is modes x alphas, not x intensities);
* ``sheet.png`` -- the study sheet: D1 | D2 | D3 virtual (top) and over the photo at 50 %
  (bottom), at the overlay intensity (D1-D3 are rendered for it even when not in ``modes``);
* ``record.json`` -- written last: the outputs with their parameters, the registration, timings
  and a fingerprint of the job's settings, the shot's input paths and the size and mtime of every
  file the shot reads (the scene's manifest, meshes and their companions; the shot's photo,
  intrinsics, markers or points, its SHOT.json and that shot's photo).

For the job: ``OUTDIR/manifest.json`` (every shot with its status, error, registration error,
outputs with parameters, timings) and ``OUTDIR/report.html`` (one self-contained file: inline
JPEG thumbnails of the sheets, links to the full images inside OUTDIR, shots sorted by
registration error, failures last).

Restart: every file is written atomically (temp + rename) and ``record.json`` last, so a shot is
finished exactly when its record exists and says done, its fingerprint matches the job and every
output it lists exists. A failed shot's folder keeps only a record.json saying so: outputs of
earlier runs there no longer match its inputs and are removed. A rerun skips finished shots (``--force`` redoes them)
and retries failed ones; a
shot whose settings or input files changed (edited, replaced or touched) is not finished. A
killed run loses only the shots in flight. Outputs of earlier runs that the job no longer
produces are removed before the shots run (listed in the manifest's ``removed``): in the job's
shot folders, the export's own file names that it no longer plans (a dropped alpha, intensity or
mode); in ``OUTDIR/shots/``, the export's files in folders of shots no longer in the job that
hold a ``record.json``, and the folder once empty. Other files, and the job's own inputs, stay.
A bad shot (unreadable photo, no markers, an error above the limit) is reported and the others
go on; the exit status is 1 when any shot failed.
PNGs are deterministic (fixed seeds, no timestamps): the same job gives the same bytes, with any
number of workers or on a cluster.

Progress goes to stderr: a bar on a terminal, one line per shot (count, name, status, ETA) in a
pipe or log file.

Execution: ``--workers 1`` runs in this process; ``--workers N`` in N spawned processes
(``ProcessPoolExecutor``, "spawn": each has its own EGL context and keeps its scene and Renderer
across shots, see :mod:`.shot`); ``--scheduler ADDRESS`` sends :func:`.shot.run_shot` to a Dask
distributed cluster, whose workers read the scene and photos from the (absolute) paths of the job
and return the encoded files, which this process writes into OUTDIR.
Killed (``kill -9``), the export takes its local workers with it (:mod:`.execute`): none
goes on writing into OUTDIR beside a rerun. A cluster's workers are the cluster's and stay; they
never write into OUTDIR, and the scheduler releases the shots of a client that is gone (one
already running finishes on its worker, and its result is dropped).

Modules (the public API is :func:`.run.run_export` and what the review shares):

* :mod:`.job` -- the job file: :func:`load_job` -> :class:`Job` (:class:`JobSettings`,
  :class:`PlannedShot`, :class:`ShotInputs`);
* :mod:`.tasks` -- :class:`ShotTask` (what a worker gets), :class:`ShotRecord` (what it hands
  back: record.json), :func:`plan_outputs`, :func:`input_files`, :func:`finished_record`;
* :mod:`.shot` -- one shot in a worker: :func:`register_shot` (also the review's),
  :func:`run_shot`;
* :mod:`.folders` -- writing a shot's folder, removing what the job no longer produces;
* :mod:`.execute` -- local workers or a Dask cluster;
* :mod:`.run` -- :func:`run_export` -> :class:`ExportResult`, progress as :class:`ShotProgress`;
* :mod:`.report` -- report.html from ``templates/report.html.j2``.

File names: :mod:`mrcheck.apps.names`.
"""
