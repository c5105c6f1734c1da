"""OpenCV pinhole cameras and the OpenGL projection built exactly from them.

Conventions (stated once, tested in tests/test_camera.py):

* Camera space is OpenCV's: x right, y down, z forward; ``X_cam = R @ X_world + t``.
* Pixel coordinates are OpenCV's: the centre of pixel column ``i`` / row ``j`` is at
  ``(u, v) = (i, j)``; ``u = fx * x / z + cx``. In GL window coordinates that centre is at
  ``(i + 0.5, j + 0.5)``, hence the ``+ 0.5`` in :func:`gl_projection`.
* Images are stored row 0 = top. The projection maps image row 0 to framebuffer row 0, so a
  framebuffer read back from GL is already in image order (no flip) and every shader can go
  from ``gl_FragCoord`` to ``(u, v)`` by subtracting 0.5.
* Lens distortion (``dist``) is carried along for the photo overlay; the renderer itself draws
  the ideal pinhole image of K.

Camera JSON (the contract other tools rely on)::

    {"width": W, "height": H, "K": [[fx,0,cx],[0,fy,cy],[0,0,1]],
     "dist": [k1,k2,p1,p2,k3] (optional), "R": 3x3, "t": [tx,ty,tz]}

Extra keys (``photo``, ``rms``, ...) are ignored, so a registered SHOT.json is a camera too.
An R within 1e-3 of a rotation (printed with a few digits) becomes the nearest rotation
(:func:`nearest_rotation`); anything further off is refused.
A ``.yml``/``.yaml`` camera file is OpenCV FileStorage instead. Reading and writing either file
is :mod:`mrcheck.core.camerafiles` (this module is the model only: it reads no file).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from typing import SupportsInt, cast

import numpy as np

from mrcheck.core.errors import MrcheckError

# the lengths OpenCV's projectPoints/undistortPoints take (0: no distortion); any other length
# passes here and fails deep inside OpenCV in the overlay or the registration
DIST_SIZES = (0, 4, 5, 8, 12, 14)


@dataclass(frozen=True)
class Camera:
    """A calibrated pinhole camera with its pose.

    Attributes
    ----------
    width, height : int
        Image size in pixels.
    K : (3, 3) float64
        Intrinsics, pixels.
    R : (3, 3) float64
        World-to-camera rotation (OpenCV convention).
    t : (3,) float64
        World-to-camera translation, world units.
    dist : (n,) float64
        OpenCV distortion coefficients: none, or 4, 5, 8, 12 or 14 (see ``DIST_SIZES``).
    """

    width: int
    height: int
    K: np.ndarray
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    t: np.ndarray = field(default_factory=lambda: np.zeros(3))
    dist: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self):
        for name, shape in (("K", (3, 3)), ("R", (3, 3)), ("t", (3,))):
            value = np.array(getattr(self, name), dtype=np.float64)
            if value.shape != shape:
                raise MrcheckError(f"camera {name} must have shape {shape}, got {value.shape}")
            if not np.all(np.isfinite(value)):
                raise MrcheckError(f"camera {name} contains NaN or infinite values")
            value.flags.writeable = False
            object.__setattr__(self, name, value)
        dist = np.array(self.dist, dtype=np.float64).reshape(-1)
        if not np.all(np.isfinite(dist)):  # the photo overlay would undistort into NaN
            raise MrcheckError("camera dist contains NaN or infinite values")
        if dist.size not in DIST_SIZES:
            raise MrcheckError(
                f"camera dist must have 4, 5, 8, 12 or 14 coefficients (OpenCV's) or none, got {dist.size}"
            )
        dist.flags.writeable = False
        object.__setattr__(self, "dist", dist)
        if int(self.width) != self.width or int(self.height) != self.height:
            raise MrcheckError("camera width and height must be whole numbers of pixels")
        object.__setattr__(self, "width", int(self.width))
        object.__setattr__(self, "height", int(self.height))
        if self.width <= 0 or self.height <= 0:
            raise MrcheckError(f"camera size must be positive, got {self.width}x{self.height}")
        if self.fx <= 0 or self.fy <= 0:
            raise MrcheckError(f"camera focal lengths must be positive, got fx={self.fx}, fy={self.fy}")
        _check_pinhole(self.K)
        object.__setattr__(self, "R", nearest_rotation(self.R))

    # -- intrinsics ---------------------------------------------------------------------------
    @property
    def fx(self) -> float:
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        return float(self.K[1, 1])

    @property
    def cx(self) -> float:
        return float(self.K[0, 2])

    @property
    def cy(self) -> float:
        return float(self.K[1, 2])

    @property
    def center(self) -> np.ndarray:
        """(3,) float64: camera centre in world coordinates, ``-R.T @ t``."""
        return -self.R.T @ self.t

    def resized(self, width: int, height: int) -> "Camera":
        """The same camera at another image size (K scaled about the pixel grid, not the origin)."""
        sx, sy = width / self.width, height / self.height
        K = self.K.copy()
        # pixel centres sit at integer u, so the continuous image edge is at -0.5
        K[0, 0] *= sx
        K[1, 1] *= sy
        K[0, 2] = (self.cx + 0.5) * sx - 0.5
        K[1, 2] = (self.cy + 0.5) * sy - 0.5
        return Camera(width, height, K, self.R, self.t, self.dist)

    def fitted(self, width=None, height=None, source=None) -> "Camera":
        """The camera at ``--width``/``--height`` (a missing one keeping the aspect ratio), or an
        error naming ``source`` when both are given in another aspect ratio.

        A calibrated camera has square pixels and one aspect ratio: both sides scaled apart would
        scale fx and fy apart and squash the image (a round bollard drawn as an ellipse). Up to one
        pixel of rounding of either side is the same aspect ratio (what one side alone rounds to).
        """
        if not (width or height):
            return self
        if width and height and abs(width * self.height - height * self.width) > max(self.width, self.height):
            w, h = fit_size(self.width, self.height, width)
            raise MrcheckError(
                f"--width {width} --height {height} is another aspect ratio than the camera's "
                f"{self.width}x{self.height} (a calibrated camera has square pixels); give only "
                f"--width or --height and the other follows (--width {width}: {w}x{h})",
                source,
            )
        return self.resized(*fit_size(self.width, self.height, width, height))

    def with_pose(self, R, t) -> "Camera":
        return Camera(self.width, self.height, self.K, R, t, self.dist)

    def view_matrix(self) -> np.ndarray:
        """(4, 4) float64 world-to-camera matrix [R | t]."""
        V = np.eye(4)
        V[:3, :3] = self.R
        V[:3, 3] = self.t
        return V

    def project(self, points_world) -> np.ndarray:
        """(n, 2) float64 pixel coordinates (OpenCV, no distortion) of world points."""
        p = (np.asarray(points_world, dtype=np.float64) @ self.R.T) + self.t
        return np.column_stack((self.fx * p[:, 0] / p[:, 2] + self.cx, self.fy * p[:, 1] / p[:, 2] + self.cy))

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def from_look_at(cls, eye, target, up, fov_y_deg: float, width: int, height: int) -> "Camera":
        """A centred camera at ``eye`` looking at ``target`` with vertical field of view in DEGREES."""
        eye, target, up = (_vec3(a, name) for a, name in ((eye, "eye"), (target, "target"), (up, "up")))
        # "not 0 < x" rather than "x <= 0": a manifest value may be nan or not a number at all
        if isinstance(fov_y_deg, bool) or not isinstance(fov_y_deg, numbers.Real) or not 0.0 < fov_y_deg < 180.0:
            raise MrcheckError(f"fov_y_deg must be between 0 and 180 degrees, got {fov_y_deg!r}")
        width, height = _whole(width, "width"), _whole(height, "height")
        if width <= 0 or height <= 0:
            raise MrcheckError(f"image size must be positive, got {width}x{height}")
        forward = target - eye
        if np.linalg.norm(forward) < 1e-12:
            raise MrcheckError("viewpoint eye and target are the same point")
        z = forward / np.linalg.norm(forward)
        x = np.cross(z, up)  # OpenCV x (right) = forward x up ... y (down) = z x x
        if np.linalg.norm(x) < 1e-9:
            raise MrcheckError("viewpoint up vector is parallel to the viewing direction")
        x /= np.linalg.norm(x)
        y = np.cross(z, x)
        R = np.stack([x, y, z])
        fy = 0.5 * height / math.tan(math.radians(fov_y_deg) / 2.0)
        K = np.array([[fy, 0.0, (width - 1) / 2.0], [0.0, fy, (height - 1) / 2.0], [0.0, 0.0, 1.0]])
        return cls(width, height, K, R, -R @ eye)

    @classmethod
    def from_dict(cls, data: dict, source="camera") -> "Camera":
        if not isinstance(data, dict):
            raise MrcheckError("camera JSON must be an object", source)
        missing = [key for key in ("width", "height", "K") if key not in data]
        if missing:
            raise MrcheckError(f"camera JSON is missing {', '.join(missing)}", source)
        try:
            return cls(
                width=_whole(data["width"], "width"),
                height=_whole(data["height"], "height"),
                K=_numbers(data["K"], "K"),
                R=_numbers(data.get("R", np.eye(3)), "R"),
                t=_numbers(data.get("t", np.zeros(3)), "t").reshape(-1),
                dist=_numbers(data.get("dist") or [], "dist"),
            )
        except MrcheckError as exc:
            raise MrcheckError(str(exc), source) from None

    def to_dict(self, pose: bool = True) -> dict:
        """The camera JSON's keys; ``pose=False`` for intrinsics only (no R, t: not renderable)."""
        out = {"width": self.width, "height": self.height, "K": self.K.tolist()}
        if self.dist.size:
            out["dist"] = self.dist.tolist()
        if pose:
            out["R"] = self.R.tolist()
            out["t"] = self.t.tolist()
        return out


_PINHOLE = "K must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]"
# the zeros and the 1 of K as written by a tool that computed them: noise up to this is no skew
_SKEW_TOLERANCE = 1e-6  # of the focal length, pixels: at most a millionth of a pixel per pixel
_ROW_TOLERANCE = 1e-9


# how far R may be from a rotation and still be one written with limited precision (a pose from
# clicks or solvePnP printed with 4-6 digits is off by 1e-6 to 1e-4); a shear, a scale or a mirror
# is off by far more and is refused
ROTATION_TOLERANCE = 1e-3
# below this R is a rotation to rounding (Rodrigues, products of rotations: 1e-15; a file printed
# with 9 or more digits, calibration/sample_cell_conveyor.json: 6.6e-10) and is kept as it is, so
# that those poses and the renders from them stay the same to the last bit
_ROUNDING = 1e-9


def nearest_rotation(R: np.ndarray) -> np.ndarray:
    """``R`` (3, 3) projected onto the nearest rotation (Frobenius norm: ``U @ V.T`` of its SVD,
    Higham 1986) when it is a rotation within :data:`ROTATION_TOLERANCE` (``R @ R.T - I`` and
    ``det(R) - 1``); an error when it is not; ``R`` itself (read-only) when it is one to rounding."""
    R = np.asarray(R, dtype=np.float64)
    off = float(np.abs(R @ R.T - np.eye(3)).max())
    det = float(np.linalg.det(R))
    if not (off <= ROTATION_TOLERANCE and abs(det - 1.0) <= ROTATION_TOLERANCE):
        raise MrcheckError("camera R is not a rotation matrix (R @ R.T must be I, det(R) = 1)")
    if off <= _ROUNDING and abs(det - 1.0) <= _ROUNDING:
        return R
    U, _, Vt = np.linalg.svd(R)
    rotation = U @ Vt  # det +1: det(R) is near 1, so no reflection to undo
    rotation.flags.writeable = False
    return rotation


def _check_pinhole(K: np.ndarray) -> None:
    """Only fx, fy, cx, cy are drawn (the projection and every shader): a skewed or unnormalised
    K would render as the plain pinhole, an image that does not match the camera. Refused rather
    than normalised: a bottom row other than [0, 0, 1] may be a wrong matrix, not a scaled one."""
    if abs(K[0, 1]) > _SKEW_TOLERANCE * K[0, 0]:
        raise MrcheckError(
            f"camera has skew K[0][1] = {K[0, 1]:g}, which mrcheck does not draw; {_PINHOLE} "
            "(recalibrate without skew, as OpenCV's calibrateCamera does)"
        )
    if abs(K[1, 0]) > _SKEW_TOLERANCE * K[1, 1]:
        raise MrcheckError(f"camera K[1][0] = {K[1, 0]:g} is not 0; {_PINHOLE}")
    if np.abs(K[2] - (0.0, 0.0, 1.0)).max() > _ROW_TOLERANCE:
        raise MrcheckError(
            f"camera K has bottom row {K[2].tolist()}, not [0, 0, 1]; {_PINHOLE} "
            "(divide K by K[2][2] if it is a scaled K)"
        )


def _whole(value, name) -> int:
    # numbers.Real takes numpy scalars too; isfinite first, as int(inf) raises (JSON allows Infinity)
    whole = None
    if not isinstance(value, bool) and isinstance(value, numbers.Real) and math.isfinite(value):
        whole = int(cast(SupportsInt, value))  # every Real converts; typeshed's numbers.Real declares no __int__
    if whole is None or whole != value:
        raise MrcheckError(f"camera {name} must be a whole number, got {value!r}")
    return whole


def _numbers(value, name) -> np.ndarray:
    """A float64 array of a JSON value, or an error naming the key (ragged lists, strings...)."""
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise MrcheckError(f"camera {name} must be an array of numbers, got {value!r}"[:200]) from None


def _vec3(value, name) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        v = None
    if v is None or v.shape != (3,) or not np.all(np.isfinite(v)):
        raise MrcheckError(f"{name} must be three finite numbers, got {value!r}")
    return v


def fit_size(own_width, own_height, width=None, height=None) -> tuple[int, int]:
    """The image size asked for: ``width`` and ``height`` as given, a missing one keeping the
    aspect ratio of ``own_width`` x ``own_height``, the own size when neither is given."""
    if width and not height:
        height = max(1, round(own_height * width / own_width))
    elif height and not width:
        width = max(1, round(own_width * height / own_height))
    return width or own_width, height or own_height


def gl_projection(camera: Camera, near: float) -> np.ndarray:
    """(4, 4) float64 GL projection for OpenCV camera-space points, exactly from K: reversed-Z
    with an infinite far plane.

    Maps camera point (x, y, z) to clip space so that window x = u + 0.5 and window y = v + 0.5
    (image row 0 in framebuffer row 0), and to window depth ``near / z`` under
    ``glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE)`` (:func:`mrcheck.render.gl.create_context`): 1 at
    the near plane, towards 0 (the cleared background) at infinity. Clip z is the constant
    ``near`` and clip w is z, so there is no far plane to choose and nothing in the matrix rounds
    with distance; a float32 depth buffer then holds ``near / z`` with the same relative
    precision (24 bits) at every distance (Reed, "Depth precision visualized", 2015). The
    principal point may be anywhere (off-centre, even outside the image).
    """
    if not 0.0 < near < math.inf:
        raise MrcheckError(f"invalid near plane {near}")
    W, H = camera.width, camera.height
    P = np.zeros((4, 4))
    P[0, 0] = 2.0 * camera.fx / W
    P[0, 2] = 2.0 * (camera.cx + 0.5) / W - 1.0
    P[1, 1] = 2.0 * camera.fy / H
    P[1, 2] = 2.0 * (camera.cy + 0.5) / H - 1.0
    P[2, 3] = near
    P[3, 2] = 1.0
    return P


__all__ = ["Camera", "fit_size", "gl_projection", "nearest_rotation", "DIST_SIZES", "ROTATION_TOLERANCE"]
