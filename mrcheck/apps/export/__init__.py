"""``mrcheck export``: batch overlays for a whole job."""
