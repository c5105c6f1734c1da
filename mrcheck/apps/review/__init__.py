"""``mrcheck review``: a local web app to review CAD-over-photo shots and mark discrepancies.

* server.py -- :func:`start` (open the source, bind the port, make the app) -> ReviewServer
  (``messages()`` to print, ``run()`` to serve); :func:`listen`;
* app.py -- :func:`create_app`: the FastAPI app over a :class:`.state.Review`;
* routes/ -- the routes per concern (pages, shots, markers, exports); models.py -- the request
  bodies; middleware.py -- token, error shape, unexpected errors; guard.py -- Host and body size;
* source.py -- what is reviewed (a job, an export folder or a scene + shots): :func:`open_source`;
* storage.py -- the markers in SQLite (WAL); suggestions.py -- markers suggested by
  ``mrcheck discrepancies``;
* renders.py -- on-demand renders in one GL worker thread, disk cache; pick.py -- Open3D ray
  casting: which part is under a pixel;
* report.py -- the HTML report (``templates/report.html.j2``) and the CSV.

File names: :mod:`mrcheck.apps.names`.
"""
