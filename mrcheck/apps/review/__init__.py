"""``mrcheck review``: a local web app to review CAD-over-photo shots and mark discrepancies.

app.py (routes), source.py (what is reviewed: a job, an export folder or a scene + shots),
storage.py (SQLite, WAL), renders.py (on-demand renders in one GL worker thread, disk cache),
pick.py (Open3D ray casting: which part is under a pixel), report.py (HTML + CSV export).
"""
