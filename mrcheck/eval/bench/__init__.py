"""``mrcheck bench``: timings of every pass, the peers (VTK, Open3D)."""
