"""Calibration boards: a board SPEC string parsed, and the board found in a photo.

Board SPEC strings: ``chessboard:COLSxROWS:SQUARE`` counts INNER corners (OpenCV's
  ``patternSize``), ``charuco:COLSxROWS:SQUARE:MARKER:DICT`` counts SQUARES (OpenCV's
  ``CharucoBoard`` size); sizes are in metres, DICT is an OpenCV predefined dictionary name
  (``DICT_6X6_250``). The board lies in its own z = 0 plane; its units only scale the (unused)
  extrinsics, never K.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from mrcheck.core.errors import MrcheckError

# fewer ChArUco corners than this cannot constrain a view's pose (six parameters) reliably
MIN_CHARUCO_CORNERS = 6
# photos longer than this are searched on a copy downscaled to it, and the corners refined in the
# photo itself: on OpenCV's 13 photos upscaled to 4032 x 3024 (a 12 MP phone photo) a search at
# full size took up to 7 s a photo (3.7 s without a board) and found 7 boards (the detectors miss
# corners blurred over many pixels); on the copy all 13, 0.4 s a photo at most
DETECT_LONG_SIDE = 1280
_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)  # OpenCV's samples


@dataclass(frozen=True)
class Board:
    """A parsed board SPEC; :meth:`detect` finds it in a grey image."""

    spec: str
    kind: str  # "chessboard" or "charuco"
    cols: int
    rows: int
    square: float
    marker: float = 0.0
    dictionary: str = ""

    def __post_init__(self):
        if self.kind == "charuco":
            aruco = cv2.aruco
            board = aruco.CharucoBoard(
                (self.cols, self.rows),
                self.square,
                self.marker,
                aruco.getPredefinedDictionary(getattr(aruco, self.dictionary)),
            )
            # the detector interpolates the chessboard corners from the markers and refines them
            # to sub-pixel accuracy itself (cornerSubPix inside detectBoard)
            object.__setattr__(self, "_charuco", (board, aruco.CharucoDetector(board)))
        else:
            grid = np.mgrid[0 : self.cols, 0 : self.rows].T.reshape(-1, 2) * self.square
            object.__setattr__(self, "_grid", np.column_stack((grid, np.zeros(len(grid)))).astype(np.float32))

    def detect(self, gray: np.ndarray, quick: bool = False):
        """(object points (n, 3) float32 metres, image points (n, 2) float32 px), or None.

        A photo longer than DETECT_LONG_SIDE px is searched on a copy downscaled to that size, and
        the corners found there are refined with cornerSubPix in the photo itself. ``quick``
        leaves out a chessboard's fallback detector (0.5 s on a 640 x 480 photo without the board).
        """
        scale = max(gray.shape) / DETECT_LONG_SIDE
        if scale <= 1:
            return self._detect(gray, quick)
        small = cv2.resize(
            gray, (round(gray.shape[1] / scale), round(gray.shape[0] / scale)), interpolation=cv2.INTER_AREA
        )
        found = self._detect(small, quick)
        if found is None:
            return None
        obj, img = found
        # pixel i of the copy covers pixels [i f, (i + 1) f) of the photo, so its centre is (i + 0.5) f - 0.5
        factor = np.array([gray.shape[1] / small.shape[1], gray.shape[0] / small.shape[0]], np.float32)
        img = (img + 0.5) * factor - 0.5
        # no 5 px cap here: a window narrower than the blur of an edge settles off the corner (on 3x
        # upscales of OpenCV's 13 photos, 5 px gave 0.66 px RMS per original pixel, a quarter
        # square 0.20, as the originals' 0.195)
        img = cv2.cornerSubPix(gray, img.reshape(-1, 1, 2), self._subpix_window(obj, img), (-1, -1), _SUBPIX_CRITERIA)
        return obj, img.reshape(-1, 2)

    def _detect(self, gray, quick):
        return self._detect_charuco(gray) if self.kind == "charuco" else self._detect_chessboard(gray, quick)

    def _detect_chessboard(self, gray, quick):
        size = (self.cols, self.rows)
        # the classic detector first: it is what OpenCV's calibration sample uses, so results match
        # it; FAST_CHECK only skips images without a board sooner
        flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_FAST_CHECK
        found, corners = cv2.findChessboardCorners(gray, size, flags=flags)
        if found:
            window = self._subpix_window(self._grid, corners.reshape(-1, 2), most=5)
            corners = cv2.cornerSubPix(gray, corners, window, (-1, -1), _SUBPIX_CRITERIA)
        elif not quick:
            # the sector-based detector copes with blur and strong distortion, and is sub-pixel already
            found, corners = cv2.findChessboardCornersSB(gray, size, flags=cv2.CALIB_CB_ACCURACY)
        if not found:
            return None
        return self._grid, corners.reshape(-1, 2).astype(np.float32)

    def _detect_charuco(self, gray):
        board, detector = self._charuco
        corners, ids, _, _ = detector.detectBoard(gray)
        if ids is None or len(ids) < MIN_CHARUCO_CORNERS or board.checkCharucoCornersCollinear(ids):
            return None  # collinear corners give no homography, calibrateCamera would fail
        obj, img = board.matchImagePoints(corners, ids)  # object points of the corners, by id
        return obj.reshape(-1, 3).astype(np.float32), img.reshape(-1, 2).astype(np.float32)

    def _subpix_window(self, obj, img, most=None):
        """cornerSubPix's winSize (a HALF size): a quarter of the smallest square in the image, at
        least 2 px (at most ``most``), and on a ChArUco board no wider than the white margin
        around its markers, which would pull the corner towards a marker's edges.

        OpenCV's calibration sample passes (11, 11), a 23 x 23 px window; where squares are smaller
        than that (left02.jpg of its own photos: 21.8 px) the window takes in the neighbouring
        corners and pulls the refined corner up to 6 px off, a 1.2 px view error instead of 0.17 px.
        """
        i, j = np.triu_indices(len(img), 1)
        # pixels per metre between two corners, at its smallest: where the board is most foreshortened
        per_metre = np.min(np.linalg.norm(img[i] - img[j], axis=1) / np.linalg.norm(obj[i] - obj[j], axis=1))
        reach = min(0.25, (self.square - self.marker) / (2 * self.square)) * self.square * per_metre
        half = int(max(2, reach) if most is None else min(most, max(2, reach)))
        return (half, half)


def parse_board(spec: str) -> Board:
    """A :class:`Board` of a SPEC string, or MrcheckError naming what is wrong with it."""
    fields = spec.split(":")
    kind = fields[0].strip().lower()
    expected = {"chessboard": 3, "charuco": 5}
    if kind not in expected:
        raise MrcheckError(f"board SPEC {spec!r}: unknown board type {fields[0]!r} (chessboard or charuco)")
    if len(fields) != expected[kind]:
        form = "chessboard:COLSxROWS:SQUARE" if kind == "chessboard" else "charuco:COLSxROWS:SQUARE:MARKER:DICT"
        raise MrcheckError(f"board SPEC {spec!r}: expected {form}")
    try:
        cols, rows = (int(n) for n in fields[1].lower().split("x"))
    except ValueError:
        raise MrcheckError(f"board SPEC {spec!r}: size {fields[1]!r} is not COLSxROWS, e.g. 9x6") from None
    smallest = 3 if kind == "chessboard" else 2  # OpenCV's chessboard detectors need 3x3 inner corners
    if cols < smallest or rows < smallest:
        raise MrcheckError(f"board SPEC {spec!r}: size must be at least {smallest}x{smallest}")
    sizes = [_length(spec, name, value) for name, value in zip(("square", "marker"), fields[2:4])]
    if kind == "chessboard":
        return Board(spec, kind, cols, rows, sizes[0])
    square, marker = sizes
    if marker >= square:
        raise MrcheckError(f"board SPEC {spec!r}: marker size must be smaller than the square size")
    dictionary = fields[4].strip().upper()
    if not dictionary.startswith("DICT_") or not isinstance(getattr(cv2.aruco, dictionary, None), int):
        raise MrcheckError(f"board SPEC {spec!r}: unknown ArUco dictionary {fields[4]!r} (e.g. DICT_6X6_250)")
    return Board(spec, kind, cols, rows, square, marker, dictionary)


def _length(spec, name, text) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (value > 0 and math.isfinite(value)):
        raise MrcheckError(f"board SPEC {spec!r}: {name} size must be a positive length in metres, got {text!r}")
    return value


__all__ = ["Board", "parse_board", "DETECT_LONG_SIDE", "MIN_CHARUCO_CORNERS"]
