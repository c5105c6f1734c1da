"""Markerless registration: snap the CAD onto the photo's edges.

Public API (stable; the review's click registration and the discrepancy check build on it):

* :func:`refine_pose` ``(scene, camera, grey, initial=None, options=None, *, renderer=None,
  edges=None, candidates=None, seed=None, pyramid=None) -> EdgeFit``: the refined pose, edge
  RMS, support share, pose uncertainty, warnings and the time per stage; raises
  :class:`EdgeFitError` on failure (``candidates``, ``seed``: what a video's frame before leaves
  for the next; ``pyramid``: :func:`photo_pyramid` of the photo made beforehand; see
  :mod:`mrcheck.apps.track`).
* :class:`EdgeOptions`, :class:`EdgeFit`, :class:`EdgeFitError`, :class:`LevelReport`,
  :class:`VisibilityRender`, :class:`~mrcheck.mr.edges.uncertainty.PoseUncertainty`.
* :func:`~mrcheck.mr.edges.model.scene_edges` (the scene's edges, to reuse between frames).

Modules: ``model`` (the CAD's visible edges), ``candidates`` (those kept between renders),
``photo`` (the photo's edges, the search along the normal), ``solver`` (residuals, robust
Gauss-Newton, covariance), ``uncertainty`` (px, mm, degrees, the weak direction), ``options``
(the settings and results), ``fitter`` (one pyramid level's fit), ``chamfer``, ``search`` and
``coarse`` (the coarse stage), ``verdict`` (the statistics and the failure tests), ``refine``
(coarse to fine), ``silhouette`` and ``region`` (the rendered outline's samples and their colour
split, ``EdgeOptions.silhouette``).
"""

from mrcheck.mr.edges.model import scene_edges
from mrcheck.mr.edges.options import EdgeFit, EdgeFitError, EdgeOptions, LevelReport, VisibilityRender
from mrcheck.mr.edges.refine import photo_pyramid, refine_pose
from mrcheck.mr.edges.uncertainty import PoseUncertainty

__all__ = [
    "refine_pose",
    "EdgeFit",
    "EdgeFitError",
    "EdgeOptions",
    "LevelReport",
    "PoseUncertainty",
    "VisibilityRender",
    "photo_pyramid",
    "scene_edges",
]
