"""Every camera and shot file mrcheck reads or writes, and the photo of a shot.

A camera JSON is :meth:`Camera.to_dict`'s keys (plus extras: a SHOT.json is a camera too); a
``.yml``/``.yaml`` file is OpenCV FileStorage with OpenCV's own key names (``camera_matrix``,
``distortion_coefficients``, ``image_width``, ...).

* :func:`load_camera`: a camera to render from (pose required unless ``need_pose=False``);
  :func:`read_camera`: a calibration's intrinsics (a pose, if any, is kept but not required);
* :func:`write_camera`: either format, atomically;
* :func:`load_shot`: a registered SHOT.json's camera and the path of its photo (the whole
  record: :mod:`mrcheck.core.shot`);
  :func:`read_photo`: that photo, RGB (or grey), checked against the camera's size.

The model (:class:`mrcheck.core.camera.Camera`) reads no file, so this module imports it and
never the reverse.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError, display
from mrcheck.core.images import max_pixels as default_max_pixels
from mrcheck.core.images import read_image
from mrcheck.core.inputs import check_input, read_input_text
from mrcheck.core.jsonfile import read_json
from mrcheck.core.output import write_text
from mrcheck.core.shot import read_shot

YAML_SUFFIXES = (".yml", ".yaml")
CAMERA_SUFFIXES = (".json",) + YAML_SUFFIXES


# the FileStorage key names OpenCV's samples and tutorials use, the first one is what we write
_YAML_KEYS = {
    "K": ("camera_matrix", "cameraMatrix", "K", "M"),
    "dist": ("distortion_coefficients", "dist_coeffs", "distCoeffs", "D", "dist"),
    "width": ("image_width", "width"),
    "height": ("image_height", "height"),
}


def _is_yaml(path: Path) -> bool:
    return path.suffix.lower() in YAML_SUFFIXES


def write_camera(path, camera: Camera, extra: dict | None = None, pose: bool = True) -> Path:
    """Camera JSON (camera keys + ``extra``), or OpenCV FileStorage YAML for .yml/.yaml, atomically.
    ``pose=False`` writes intrinsics only (no R, t), which a render refuses rather than standing
    the camera at the world origin."""
    path, extra = Path(path), dict(extra or {})
    if not _is_yaml(path):
        text = json.dumps({**camera.to_dict(pose), **extra}, indent=2) + "\n"
        write_text(path, text)
        return path
    fs = cv2.FileStorage(".yml", cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_MEMORY)
    fs.write("image_width", camera.width)
    fs.write("image_height", camera.height)
    fs.write("camera_matrix", camera.K)
    fs.write("distortion_coefficients", camera.dist.reshape(-1, 1))  # 5x1, as the chessboard sample
    if pose:
        fs.write("R", camera.R)  # the samples' layout (intrinsics only) has none
        fs.write("t", camera.t.reshape(3, 1))
    if "rms" in extra:
        fs.write("avg_reprojection_error", float(extra.pop("rms")))
    if "per_view_errors" in extra:
        errors = extra.pop("per_view_errors")
        fs.write("per_view_reprojection_errors", np.array(list(errors.values()), np.float64).reshape(-1, 1))
        _write_strings(fs, "views", errors)  # file names cannot be FileStorage keys, hence a list
    for key, value in extra.items():
        if isinstance(value, str):
            fs.write(key, display(value))
        elif isinstance(value, (int, float)) and not isinstance(value, bool):
            fs.write(key, value)
        elif isinstance(value, list) and all(isinstance(v, str) for v in value):
            _write_strings(fs, key, value)
        elif isinstance(value, dict):  # std: one entry per parameter, like OpenCV's own stdDev keys
            for sub, v in value.items():
                fs.write(f"{key}_{sub}", np.asarray(v, np.float64).reshape(-1, 1) if isinstance(v, list) else float(v))
    text = fs.releaseAndGetString()
    write_text(path, text)
    return path


def _write_strings(fs, key, values):
    # display(): OpenCV takes strings as UTF-8 and crashes on a file name that is not valid UTF-8
    fs.startWriteStruct(key, cv2.FileNode_SEQ)
    for value in values:
        fs.write("", display(value))
    fs.endWriteStruct()


def load_camera(path, need_pose=True) -> Camera:
    """A camera file: our camera JSON, or OpenCV FileStorage YAML for .yml/.yaml.

    A calibration (OpenCV's YAML, or ``mrcheck calibrate``'s JSON) holds intrinsics only; with
    ``need_pose`` (a render) a file without R and t is an error rather than a camera silently
    standing at the world origin.
    """
    path = Path(path)
    if _is_yaml(path):
        data, kind = read_yaml_camera(path), "OpenCV YAML camera"
    else:
        data, kind = read_json(path, "camera"), "camera JSON"
    camera = Camera.from_dict(data, path)  # the intrinsics checked first
    if need_pose and not ("R" in data and "t" in data):
        raise MrcheckError(
            f"{kind} has intrinsics but no pose (R and t); register a photo with it "
            "(mrcheck register --intrinsics) and use the SHOT.json",
            path,
        )
    return camera


def read_camera(path) -> Camera:
    """A :class:`Camera` from our camera JSON or an OpenCV calibration YAML (no pose: R = I, t = 0)."""
    return load_camera(path, need_pose=False)


def load_shot(path) -> tuple[Camera, Path]:
    """The camera of a registered SHOT.json and the absolute path of its photo (:func:`mrcheck.core.shot.read_shot`)."""
    shot = read_shot(path)
    assert shot.photo is not None  # read_shot refuses a file without one
    return shot.camera, shot.photo


def read_photo(path, camera: Camera | None = None, grey: bool = False, max_pixels: int | None = None) -> np.ndarray:
    """The photo of a shot: (H, W, 3) uint8 RGB, or (H, W) uint8 with ``grey``, or a one-line
    error. Given the shot's ``camera``, a photo of another size is an error too; ``max_pixels``
    (None: ``mrcheck --max-pixels``, :func:`mrcheck.core.images.max_pixels`): a photo of more
    pixels is refused before it is decoded (:func:`mrcheck.core.images.check_pixels`)."""
    limit = default_max_pixels() if max_pixels is None else max_pixels
    image = read_image(path, "photo", grey=grey, max_pixels=limit)
    h, w = image.shape[:2]
    if camera is not None and (w, h) != (camera.width, camera.height):
        raise MrcheckError(f"photo is {w}x{h} but the shot was registered at {camera.width}x{camera.height}", path)
    return image


def read_yaml_camera(path: Path) -> dict:
    """The camera dict (:meth:`Camera.from_dict`'s keys) of an OpenCV FileStorage YAML.

    R and t are there only when the file has them: :func:`load_camera` tells an intrinsics file
    from a posed camera by that.
    """
    path = Path(path)
    if check_input(path, "camera file").st_size == 0:
        raise MrcheckError("cannot read OpenCV YAML camera: the file is empty", path)
    # parsed from memory: FileStorage given the name crashes on one that is not valid UTF-8
    text = read_input_text(path, "OpenCV YAML camera")
    try:
        fs = cv2.FileStorage(text, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
        try:
            if not fs.isOpened():
                raise MrcheckError("cannot read OpenCV YAML camera", path)
            values = {name: _yaml_value(fs, keys) for name, keys in _YAML_KEYS.items()}
            values["R"], values["t"] = _yaml_value(fs, ("R",)), _yaml_value(fs, ("t",))
        finally:
            fs.release()
    except (cv2.error, SystemError) as exc:
        # a parse error surfaces from the FileStorage constructor as a SystemError caused by the
        # cv2.error, a truncated matrix from FileNode.mat() as the cv2.error itself
        raise MrcheckError(
            f"cannot read OpenCV YAML camera (truncated or malformed): {_cv_reason(exc)}", path
        ) from None
    if values["K"] is None:
        raise MrcheckError(f"OpenCV YAML has no camera matrix ({' or '.join(_YAML_KEYS['K'])})", path)
    if values["width"] is None or values["height"] is None:
        raise MrcheckError(
            "OpenCV YAML has no image_width/image_height; pass a camera JSON with width and height", path
        )
    for key in ("K", "R"):  # a plain 9-number list is a 3x3 matrix too
        if values[key] is not None and values[key].size == 9:
            values[key] = values[key].reshape(3, 3)
    data = {key: value.tolist() for key, value in values.items() if value is not None}
    for key in ("width", "height"):  # a number, or what it is, for Camera.from_dict to reject
        data[key] = values[key].item() if values[key].size == 1 else data[key]
    for key in ("t", "dist"):  # a 3x1 or 1x5 matrix is a vector
        if key in data:
            data[key] = np.ravel(values[key]).tolist()
    return data


def _cv_reason(exc) -> str:
    """OpenCV's own words from "OpenCV(5.0.0) FILE:LINE: error: (-212:Parsing error) WHAT in function 'WHERE'"."""
    error = exc if isinstance(exc, cv2.error) else exc.__cause__ or exc
    return str(error).split(" error: ", 1)[-1].strip()


def _yaml_value(fs, keys):
    """The first present key's value as a float64 array (matrix, number or list), else None."""
    for key in keys:
        node = fs.getNode(key)
        if node.empty() or node.isNone():
            continue
        if node.isSeq():
            return np.array([_number(node.at(i)) for i in range(node.size())], np.float64)
        if node.isInt() or node.isReal() or node.isString():
            return np.array(_number(node), np.float64)
        matrix = node.mat()
        if matrix is not None:
            return np.asarray(matrix, np.float64)
    return None


def _number(node) -> float:
    # FileNode.real() of a string is DBL_MAX, a plausible-looking number; NaN is rejected by Camera
    return node.real() if node.isInt() or node.isReal() else math.nan


__all__ = [
    "load_camera",
    "read_camera",
    "read_yaml_camera",
    "write_camera",
    "load_shot",
    "read_photo",
    "CAMERA_SUFFIXES",
    "YAML_SUFFIXES",
]
