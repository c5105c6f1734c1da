"""Factory scenes for mrcheck: the procedural generator and the scenes it shipped.

``sample_cell/`` is the embedded sample scene (``build_sample_cell.py`` made it); the generator
(``mrcheck scene generate``) writes further scenes as a manifest plus GLB meshes.
"""
