"""Foundations every layer uses: errors, JSON, atomic output, images, resources, cameras and their files."""
