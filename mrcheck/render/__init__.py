"""Rendering: settings, GL context, G-buffer, culling, LOD, the AO passes (ao/), blur, composite."""
