"""The scene model (Scene, Part), manifests, scene info, URDF robots, as-built variants."""
