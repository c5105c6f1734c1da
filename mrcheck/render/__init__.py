"""Rendering: settings, GL context, G-buffer, culling, LOD, the AO passes (ao/), blur, composite.

Public API: :class:`mrcheck.render.renderer.Renderer` (``render(camera, modes, settings)`` returns a
``Frame``: each mode's ``RenderResult`` by name, the depth, optionally the normals;
``passes(camera)`` the passes one at a time, ``release()``), :mod:`mrcheck.render.settings`
(``RenderSettings``, ``MODES``, ``STUDY_LABELS`` and every default the CLI shows), and
:mod:`mrcheck.render.views` (what ``render`` and ``demo`` do).
"""
