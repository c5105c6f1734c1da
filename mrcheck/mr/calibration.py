"""Camera calibration from photos of a chessboard or ChArUco board.

Conventions:

* Board SPEC strings: :mod:`mrcheck.mr.boards`.
* Pixel coordinates and K are OpenCV's (see :mod:`mrcheck.core.camera`); ``dist`` is OpenCV's
  ``[k1, k2, p1, p2, k3]``. Errors are RMS reprojection errors in pixels: ``rms`` over all
  points of the kept views, ``per_view_errors`` per view (``calibrateCameraExtended``).
* A calibrated camera has no pose: R = I, t = 0 (the camera frame is the world frame).
* Output: our camera JSON (:func:`mrcheck.core.camerafiles.read_camera` reads it; extra keys rms, per_view_errors,
  rejected_views, skipped_views, duplicate_views, std, board), or for ``.yml``/``.yaml``
  OpenCV FileStorage in the layout of OpenCV's calibration samples (``image_width``,
  ``image_height``, ``camera_matrix``, ``distortion_coefficients``, ``avg_reprojection_error``),
  which it reads too.

Views where the board is not found (whatever their size) and unreadable images are skipped with
a warning (:func:`mrcheck.core.errors.warn`); the views with the board must share one size; a photo given twice (same
file or same bytes) is used once; outlier views (RMS above ``max_view_error``, by default above
``max(3 x median, 1 px)`` of the first calibration) are rejected and the camera is calibrated
again without them, until every view kept is within the threshold.
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import os
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import cv2
import numpy as np

from mrcheck.core.camera import Camera
from mrcheck.core.camerafiles import CAMERA_SUFFIXES, write_camera
from mrcheck.core.errors import MrcheckError, display, warn
from mrcheck.core.images import decode_image, max_pixels
from mrcheck.core.inputs import read_input, real_path
from mrcheck.core.output import check_not_inputs, check_output_path
from mrcheck.core.progress import Progress, no_progress
from mrcheck.mr.boards import Board, parse_board

DEFAULT_MIN_VIEWS = 5
# Zhang's method (cv2.calibrateCamera) gets two equations on the intrinsics from each view of a
# flat board, so three views are the fewest that determine fx, fy, cx, cy; with fewer it fits the
# photos (a low RMS) with a wrong camera: from OpenCV's left01.jpg alone fx 938 +/- 91 (533 true)
MIN_VIEWS_FLOOR = 3

# a standard deviation above 1 % of the focal length marks fx, fy, cx or cy as poorly determined
# (for cx, cy it is an angle: 1 % is 0.6 deg). OpenCV's std is the formal one and underestimates
# the error with few views: over the 286 three-photo subsets of OpenCV's 13 chessboard photos fx
# was up to 7.6 % off at a 1.3 % std; 1 % flags every subset more than 3 % off in f or in the
# principal point, while no five-photo subset comes above 0.64 % (all 13 photos: 0.08 %). The
# distortion coefficients are not checked one by one: k1, k2, k3 trade off against each other (all
# 13 photos: k2 = 0.025 +/- 0.042) while the curve they make together is well determined.
POOR_STD_FRACTION = 0.01
# "3 x median" catches a view far worse than its peers; the 1 px floor keeps a set of very
# good views (median 0.1 px) from losing ordinary ones at 0.4 px
OUTLIER_FACTOR = 3.0
OUTLIER_FLOOR_PX = 1.0
# photos a wrong board SPEC's near sizes are tried on, at most (some milliseconds a try)
HINT_PHOTOS = 5


# -- calibration --------------------------------------------------------------------------------
@dataclass
class Calibration:
    """One cv2.calibrateCameraExtended result over the views named ``names``."""

    names: list
    rms: float
    K: np.ndarray
    dist: np.ndarray
    std: np.ndarray  # OpenCV's stdDeviationsIntrinsics: fx, fy, cx, cy, then the dist coefficients
    per_view: np.ndarray

    def std_dict(self) -> dict:
        s = [float(v) for v in self.std]
        return {"fx": s[0], "fy": s[1], "cx": s[2], "cy": s[3], "dist": s[4 : 4 + len(self.dist)]}


def _calibrate(views: dict, size) -> Calibration:
    """Bit-reproducible: the same photos give the same bytes in any order and on any machine load.

    OpenCV 5's solver (SchurLMSolver in modules/calib/src/calibration.cpp) computes each view's
    Jacobian in a parallel_for_ (JAccumulator) and adds its share of the normal equations (U, ea)
    and of the error into shared sums under a mutex, in whatever order the threads get there;
    floating-point addition is not associative, and some 30 Levenberg-Marquardt steps carry the
    difference up to the 10th digit of fx. One OpenCV thread adds the views in a fixed order, and
    that order is the views' own corners (not the order the photos were given in).
    """
    names = list(views)
    order = sorted(names, key=lambda n: (views[n][1].tobytes(), views[n][0].tobytes()))
    try:
        with _one_opencv_thread():
            rms, K, dist, _, _, std, _, per_view = cv2.calibrateCameraExtended(
                [views[n][0] for n in order], [views[n][1] for n in order], size, None, None
            )
    except cv2.error as exc:
        raise MrcheckError(f"calibration failed ({exc.err})") from None
    if not (np.all(np.isfinite(K)) and np.all(np.isfinite(dist)) and math.isfinite(rms)):
        raise MrcheckError("calibration failed (non-finite result); use more views at varied angles")
    error = dict(zip(order, per_view.reshape(-1)))
    return Calibration(names, float(rms), K, dist.reshape(-1), std.reshape(-1), np.array([error[n] for n in names]))


@contextlib.contextmanager
def _one_opencv_thread():
    """OpenCV's parallel_for_ on one thread (process-wide) while the block runs, then as before."""
    before = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        cv2.setNumThreads(before)


def _read_image(path: Path):
    """(the file's bytes, its grey image, the problem): the image None when the file cannot be
    read or decoded, and the problem says why ("image is empty (0 bytes)"); the bytes None
    when it cannot be read. A missing file or a folder is an error (a mistyped argument): a
    photo that cannot be used is skipped. The photo is read once: its bytes tell a duplicate,
    imdecode applies EXIF rotation as imread."""
    if path.is_dir():
        raise MrcheckError("is a folder, not an image (give the photos themselves, e.g. DIR/*.jpg)", path)
    if not os.path.lexists(path):
        raise MrcheckError("image not found", path)
    try:
        data = read_input(path, "image")
    except MrcheckError as exc:  # a symlink loop, a broken link, permission, a FIFO, empty
        return None, None, exc.problem
    try:
        return data, decode_image(data, path, "image", grey=True, max_pixels=max_pixels()), None
    except MrcheckError as exc:
        return data, None, exc.problem


def _duplicate(seen: dict, name, path: Path, data):
    """(first name, how) when this photo came before, as the same file or as the same bytes under
    another name (a copy); else None, and the photo is recorded in ``seen``."""
    keys = {"the same file as": real_path(path)}
    if data is not None:
        keys["identical to"] = hashlib.sha256(data).digest()
    for how, key in keys.items():
        if key in seen:
            return seen[key], how
    seen.update(dict.fromkeys(keys.values(), name))
    return None


class Detected(NamedTuple):
    """What :func:`detect_views` found; every image given is in one of views, skipped, duplicates."""

    views: dict  # {name: (object points, image points)}
    size: tuple  # (width, height) of the views, None without any
    skipped: list  # names without the board or unreadable, in the order given
    duplicates: list  # names of photos given before (the first one is used)
    without_board: list  # the readable ones among skipped
    unreadable: dict  # the others among skipped: {name: why it cannot be used}


def detect_views(images, board: Board, progress: Progress = no_progress) -> Detected:
    """The board in each photo; a warning for each photo skipped; ``progress`` shows the photos
    done (a photo takes up to seconds).

    The size is that of the photos where the board is found: a photo without it is skipped
    whatever its size (a stray photo in the glob must not fail the calibration). A photo given
    twice (the same file, or a copy with the same bytes) is used once: twice would weigh its view
    double and count it as two photos.
    """
    views, sizes, skipped, duplicates, without_board, unreadable, seen = {}, {}, [], [], [], {}, {}
    # closing: a bar is taken down on an error too, so the error line starts a clean line
    with contextlib.closing(progress(images, "finding the board", "photo")) as bar:
        for name in bar:
            data, gray, problem = _read_image(Path(name))
            first = _duplicate(seen, name, Path(name), data)
            if first is not None:
                warn(f"{first[1]} {first[0]}, used once", name)
                duplicates.append(name)
                continue
            if gray is None:
                warn(f"{problem}, skipped", name)
                skipped.append(name)
                unreadable[name] = problem
                continue
            points = board.detect(gray)
            if points is None:
                warn("board not found", name)
                skipped.append(name)
                without_board.append(name)
            else:
                views[name], sizes[name] = points, (gray.shape[1], gray.shape[0])
    return Detected(views, _common_size(sizes), skipped, duplicates, without_board, unreadable)


def _common_size(sizes: dict):
    """The (width, height) most photos with the board share (a tie: the first one's), or
    MrcheckError naming the first photo of another size: that one is the odd one out."""
    if not sizes:
        return None
    size, count = Counter(sizes.values()).most_common(1)[0]  # equal counts: in order of first appearance
    odd = [name for name, shape in sizes.items() if shape != size]
    if odd:
        more = f" ({len(odd) - 1} more of another size)" if len(odd) > 1 else ""
        width, height = sizes[odd[0]]
        raise MrcheckError(
            f"image is {width}x{height}, but {count} of the {len(sizes)} photos with the board are "
            f"{size[0]}x{size[1]}{more}; all views must come from one camera at one resolution",
            odd[0],
        )
    return size


def checked_min_views(min_views) -> int:
    """``--min-views`` (None: the default), or MrcheckError when it is below MIN_VIEWS_FLOOR."""
    min_views = DEFAULT_MIN_VIEWS if min_views is None else int(min_views)
    if min_views < MIN_VIEWS_FLOOR:
        raise MrcheckError(
            f"--min-views must be at least {MIN_VIEWS_FLOOR}, got {min_views}: Zhang's method gets two "
            "equations on the camera from each photo of a flat board, so fewer photos leave it "
            "undetermined (a low RMS error with a wrong camera)"
        )
    return min_views


@dataclass(frozen=True)
class SolvedViews:
    """:func:`calibrate_views`' result: the camera (no pose), the RMS error over the views kept,
    {view: its RMS error} of those, {rejected view: its error}, the outlier threshold (px) and
    OpenCV's standard deviations ({"fx", "fy", "cx", "cy": px, "dist": [...]})."""

    camera: Camera
    rms: float
    per_view_errors: dict
    rejected: dict
    threshold: float
    std: dict


def calibrate_views(views: dict, size, board: Board, min_views=None, max_view_error=None) -> SolvedViews:
    """The camera of board detections already made, ``views``: {name: (object points, image
    points)} of images of ``size`` (width, height), as :meth:`Board.detect` gives them; outlier
    views rejected as ``mrcheck calibrate`` does (module docstring). ``mrcheck calibrate`` and the
    review's "Calibrate" (its views come from a video, not files) share it; MrcheckError when
    fewer than ``min_views`` views are given or remain."""
    min_views = checked_min_views(min_views)
    if len(views) < min_views:
        raise MrcheckError(f"{_count(len(views), 'view')} of board {board.spec}, need at least {min_views}")
    result, rejected, threshold = _without_outliers(views, size, min_views, max_view_error)
    return SolvedViews(
        Camera(size[0], size[1], result.K, dist=result.dist),
        result.rms,
        {n: float(e) for n, e in zip(result.names, result.per_view)},
        rejected,
        threshold,
        result.std_dict(),
    )


def calibrate(images, board: Board, min_views=None, max_view_error=None, progress: Progress = no_progress):
    """Detect, calibrate, reject outlier views and recalibrate until every kept view is within the threshold.

    Returns (camera, extra, report lines); ``extra`` holds the JSON's rms, per_view_errors, ...
    """
    min_views = checked_min_views(min_views)
    found = detect_views(images, board, progress)
    views, size, skipped, duplicates = found.views, found.size, found.skipped, found.duplicates
    # a board missing from most photos that could be read more likely has a wrong SPEC than bad photos
    hint = _spec_hint(board, found.without_board) if len(views) < len(found.without_board) else ""
    if len(views) < min_views:
        repeats = f" ({_count(len(duplicates), 'duplicate')} not counted)" if duplicates else ""
        raise MrcheckError(
            f"board found in only {len(views)} of {len(images) - len(duplicates)} images{repeats}, "
            f"need at least {min_views} (--min-views){_unreadable(found.unreadable)}{hint}"
        )
    if hint:
        warn(
            f"found in only {len(views)} of {len(views) + len(found.without_board)} readable images{hint}",
            f"board {board.spec}",
        )
    solved = calibrate_views(views, size, board, min_views, max_view_error)
    camera, rejected = solved.camera, solved.rejected
    extra = {
        "rms": solved.rms,
        "per_view_errors": solved.per_view_errors,
        "rejected_views": list(rejected),
        "skipped_views": skipped,
        "duplicate_views": duplicates,
        "std": solved.std,
        "board": board.spec,
    }
    return camera, extra, _report(camera, extra, rejected, solved.threshold, len(images))


def _unreadable(problems: dict, listed: int = 5) -> str:
    """ "; 5 images cannot be used (image is empty (0 bytes): a.jpg, b.jpg, ...)": the photos that
    could not be read, grouped by their problem, at most ``listed`` names per problem."""
    if not problems:
        return ""
    groups: dict = {}
    for name, problem in problems.items():
        groups.setdefault(problem, []).append(display(name))
    parts = [
        f"{problem}: {', '.join(names[:listed])}" + (f" and {len(names) - listed} more" if len(names) > listed else "")
        for problem, names in groups.items()
    ]
    return f"; {_count(len(problems), 'image')} cannot be used ({'; '.join(parts)})"


def _spec_hint(board: Board, photos) -> str:
    """ "; " + how COLSxROWS counts on this type of board, and a SPEC of a near size that finds the
    board in one of the first HINT_PHOTOS photos (the usual slips: squares counted for inner
    corners or the reverse, COLS and ROWS swapped), if one does."""
    cols, rows = board.cols, board.rows
    if board.kind == "chessboard":
        hint = "chessboard COLSxROWS counts the inner corners, where four squares meet (a board of 10x7 squares is 9x6)"
        # the larger sizes first: a detector can lock onto a part of the board, a smaller size
        # (the chessboard detectors do not mind COLS and ROWS swapped)
        near = [(cols, rows - 1), (cols - 1, rows), (cols - 1, rows - 1)]
    else:
        hint = (
            "charuco COLSxROWS counts the squares, across the board as it was made (the way its marker "
            "ids count up) and then down"
        )
        near = [(rows, cols), (cols + 1, rows + 1), (rows + 1, cols + 1)]
    kind, _, rest = board.spec.split(":", 2)
    candidates = []
    for size in near:
        try:
            candidates.append(parse_board(f"{kind}:{size[0]}x{size[1]}:{rest}"))
        except MrcheckError:
            pass  # below the smallest board
    for photo in photos[:HINT_PHOTOS]:  # the first may be a stray photo without any board
        gray = _read_image(Path(photo))[1]
        for candidate in candidates:
            if candidate.detect(gray, quick=True) is not None:
                return f"; {hint}; --board {candidate.spec} finds a board in {photo}"
    return f"; {hint}"


def _without_outliers(views, size, min_views, max_view_error):
    """(the calibration on the views within the threshold, {rejected name: its error}, threshold).

    The threshold is set once, from the first calibration. Rejecting views changes the camera and
    with it the errors of the others, which can then exceed the threshold: the rejection repeats
    until none does. Each round drops a view or more and fewer than ``min_views`` left is an error,
    so it ends.
    """
    result = _calibrate(views, size)
    threshold = (
        max_view_error
        if max_view_error is not None
        else max(OUTLIER_FACTOR * float(np.median(result.per_view)), OUTLIER_FLOOR_PX)
    )
    rejected = {}
    while worse := {n: float(e) for n, e in zip(result.names, result.per_view) if e > threshold}:
        rejected.update(worse)
        kept = {n: v for n, v in views.items() if n not in rejected}
        if len(kept) < min_views:
            raise MrcheckError(
                f"only {len(kept)} views have an RMS error <= {threshold:.3g} px, need at least "
                f"{min_views}; loosen --max-view-error or add views"
            )
        result = _calibrate(kept, size)
    return result, rejected, threshold


def _report(camera, extra, rejected, threshold, n_images) -> list:
    used = extra["per_view_errors"]
    std = extra["std"]
    # every image given is in exactly one of the four counts
    skipped, repeats = len(extra["skipped_views"]), _count(len(extra["duplicate_views"]), "duplicate")
    lines = [
        f"board {extra['board']}: {len(used)} of {n_images} images used, {len(rejected)} rejected, "
        f"{skipped} without a board or unreadable, {repeats}"
    ]
    lines += [f"  not found/skipped: {name}" for name in extra["skipped_views"]]
    lines += [f"  duplicate, used once: {name}" for name in extra["duplicate_views"]]
    lines += [f"  rejected: {name} ({err:.3f} px > {threshold:.3f} px)" for name, err in rejected.items()]
    lines.append(f"RMS reprojection error: {extra['rms']:.4f} px")
    lines.append("per-view RMS error (px):")
    lines += [f"  {name}  {err:.4f}" for name, err in used.items()]
    for key in ("fx", "fy", "cx", "cy"):
        lines.append(f"{key} = {getattr(camera, key):.3f} +/- {std[key]:.3f} px")
    dist = ", ".join(
        f"{k}={v:.5g}+/-{s:.2g}" for k, v, s in zip(("k1", "k2", "p1", "p2", "k3"), camera.dist, std["dist"])
    )
    lines.append(f"dist: {dist}")
    return lines


def _count(n, noun) -> str:
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def poorly_determined(camera, std):
    """A warning naming fx, fy, cx, cy whose standard deviation is above POOR_STD_FRACTION of the
    focal length, or None."""
    focal = {"fx": camera.fx, "fy": camera.fy, "cx": camera.fx, "cy": camera.fy}
    poor = [
        f"{key} = {getattr(camera, key):.1f} +/- {std[key]:.1f} px"
        for key, f in focal.items()
        if not std[key] <= POOR_STD_FRACTION * f
    ]  # "not <=": a NaN std is poor too
    if not poor:
        return None
    return (
        f"{', '.join(poor)}: poorly determined (standard deviation above {POOR_STD_FRACTION:.0%} of the focal "
        "length); add photos with the board tilted different ways and reaching into the image corners"
    )


@dataclass(frozen=True)
class Calibrated:
    """What ``mrcheck calibrate`` did: the camera written to ``output``, the report's lines, and
    a warning when fx, fy, cx or cy are poorly determined (else None)."""

    camera: Camera
    output: Path
    report: list
    warning: str | None


def calibrate_command(
    images, board, output, min_views=None, max_view_error=None, progress: Progress = no_progress
) -> Calibrated:
    """The ``mrcheck calibrate`` command: everything checked before the work, output written last."""
    spec = parse_board(board)
    output = check_output_path(output, CAMERA_SUFFIXES, "camera output")
    check_not_inputs([output], [("an image", images)])  # a glob of a folder takes in its old camera file too
    camera, extra, report = calibrate(images, spec, min_views, max_view_error, progress)
    write_camera(output, camera, extra, pose=False)  # a calibration has no pose
    problem = poorly_determined(camera, extra["std"])
    return Calibrated(camera, output, report, problem and f"{output}: {problem}")


__all__ = [
    "detect_views",
    "calibrate",
    "calibrate_views",
    "checked_min_views",
    "poorly_determined",
    "SolvedViews",
    "calibrate_command",
    "Calibrated",
    "Detected",
    "DEFAULT_MIN_VIEWS",
]
