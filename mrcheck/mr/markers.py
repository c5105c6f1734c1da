"""Marker maps and the detection of ArUco/AprilTag markers and ChArUco boards in a photo.

Marker map JSON (world coordinates in metres, the scene's frame)::

    {"dictionary": "DICT_6X6_250",
     "markers": [{"id": 7, "corners": [[x,y,z], [x,y,z], [x,y,z], [x,y,z]]}, ...],
     "charuco_boards": [{"squares": [5, 7], "square": 0.04, "marker": 0.02,
                         "dictionary": "DICT_6X6_250", "pose": {"R": 3x3, "t": [x,y,z]}}]}

* ``corners`` are a marker's four OUTER corners (the outer edge of the black border) in
  OpenCV's order: top-left, top-right, bottom-right, bottom-left, as seen from the front.
  A marker may name its own ``dictionary``; otherwise the map's applies.
* A ChArUco board is ``squares`` = [columns, rows] of ``square`` metres with ``marker``-metre
  markers; ``pose`` is board-to-world (``X_world = R @ X_board + t``); the board's own frame is
  OpenCV's (origin at the top-left chessboard corner, x along a row, y down the columns, z into
  the board). Optional ``ids`` (the board's marker ids in board order, for several boards of one
  dictionary) and ``legacy`` (true for boards printed with OpenCV < 4.6 and an even row count).
* A dictionary is any OpenCV predefined name (``DICT_4X4_50`` ... ``DICT_APRILTAG_36h11``).

Detection gives, per marker or board seen, its image points and the matching world points;
marker corners are refined to subpixel accuracy, ChArUco corners are chessboard saddle points
(also subpixel). Nothing here estimates a pose: see :mod:`mrcheck.mr.registration`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from mrcheck.core.errors import MrcheckError
from mrcheck.core.jsonfile import number_problem, read_json


def dictionary(name, source=None) -> cv2.aruco.Dictionary:
    """The OpenCV predefined dictionary called ``name`` (``DICT_APRILTAG_36h11`` and the like)."""
    value = None
    if isinstance(name, str) and name.upper().startswith("DICT_"):
        # OpenCV spells AprilTag families both ways (DICT_APRILTAG_36h11, DICT_APRILTAG_36H11)
        value = getattr(cv2.aruco, name, getattr(cv2.aruco, name.upper(), None))
    if not isinstance(value, int):
        raise MrcheckError(
            f"unknown marker dictionary {name!r} (use an OpenCV name such as DICT_6X6_250 or DICT_APRILTAG_36h11)",
            source,
        )
    return cv2.aruco.getPredefinedDictionary(value)


@dataclass(frozen=True)
class Board:
    """A ChArUco board of the map, placed in the world."""

    index: int
    dictionary: str
    board: cv2.aruco.CharucoBoard
    R: np.ndarray
    t: np.ndarray

    @property
    def marker_ids(self) -> set:
        return {int(i) for i in np.asarray(self.board.getIds()).ravel()}

    def corners_world(self) -> np.ndarray:
        """(n, 3) world positions of the board's chessboard corners, in ChArUco id order."""
        return np.asarray(self.board.getChessboardCorners(), np.float64).reshape(-1, 3) @ self.R.T + self.t


@dataclass(frozen=True)
class MarkerMap:
    """Standalone markers ``{dictionary name: {id: (4, 3) world corners}}`` and ChArUco boards."""

    markers: dict
    boards: tuple = ()

    @property
    def dictionaries(self) -> list:
        names = list(self.markers) + [b.dictionary for b in self.boards]
        return list(dict.fromkeys(names))  # ordered, unique


@dataclass
class Group:
    """Image/world point pairs of one marker or board. A marker is kept or rejected as a whole
    (one bad corner means a bad detection or a moved marker), a board corner by corner."""

    label: dict
    pixels: np.ndarray
    world: np.ndarray
    atomic: bool = True


@dataclass
class Detection:
    groups: list = field(default_factory=list)
    unknown: list = field(default_factory=list)  # markers in the photo but not in the map
    unseen: list = field(default_factory=list)  # markers (and boards) of the map not found


def load_marker_map(path) -> MarkerMap:
    return parse_marker_map(read_json(path, "marker map"), Path(path))


def parse_marker_map(data, source="marker map") -> MarkerMap:
    """Validate a marker map (the parsed JSON) into a :class:`MarkerMap`; errors name ``source``."""
    if isinstance(data, MarkerMap):
        return data
    if not isinstance(data, dict):
        raise MrcheckError("marker map must be a JSON object", source)
    markers_in, boards_in = data.get("markers") or [], data.get("charuco_boards") or []
    if not isinstance(markers_in, list) or not isinstance(boards_in, list):
        raise MrcheckError("marker map 'markers' and 'charuco_boards' must be lists", source)
    if not markers_in and not boards_in:
        raise MrcheckError("marker map has no markers and no charuco_boards", source)

    markers: dict = {}
    for k, entry in enumerate(markers_in):
        where = f"marker #{k}"
        if not isinstance(entry, dict):
            raise MrcheckError(f"{where} must be an object with 'id' and 'corners'", source)
        name = entry.get("dictionary", data.get("dictionary"))
        if name is None:
            raise MrcheckError(f"{where}: no 'dictionary' (give one for the map or the marker)", source)
        size = _dictionary_size(name, source)
        marker_id = entry.get("id")
        if isinstance(marker_id, bool) or not isinstance(marker_id, int) or not 0 <= marker_id < size:
            raise MrcheckError(
                f"{where}: id must be a whole number 0..{size - 1} for {name}, got {marker_id!r}", source
            )
        corners = _array(entry.get("corners"), (4, 3), f"marker {marker_id} corners", source)
        _check_quad(corners, f"marker {marker_id}", source)
        if marker_id in markers.setdefault(name, {}):
            raise MrcheckError(f"marker {marker_id} ({name}) appears twice", source)
        markers[name][marker_id] = corners

    boards = []
    for k, entry in enumerate(boards_in):
        board = _parse_board(k, entry, data.get("dictionary"), source)
        taken = set(markers.get(board.dictionary, {}))
        for other in boards:
            if other.dictionary == board.dictionary:
                taken |= other.marker_ids
        clash = sorted(board.marker_ids & taken)
        if clash:
            # the same id in two places of one dictionary cannot be told apart in a photo
            raise MrcheckError(
                f"charuco board #{k} reuses marker ids {clash[:5]} of {board.dictionary}; give the board other 'ids'",
                source,
            )
        boards.append(board)
    return MarkerMap(markers, tuple(boards))


def _dictionary_size(name, source) -> int:
    return int(dictionary(name, source).bytesList.shape[0])


def _array(value, shape, what, source) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        array = None
    if array is None or array.shape != shape or not np.all(np.isfinite(array)):
        raise MrcheckError(f"{what} must be {' x '.join(map(str, shape))} finite numbers", source)
    return array


def _check_quad(corners, what, source) -> None:
    sides = np.linalg.norm(corners - np.roll(corners, 1, axis=0), axis=1)
    if sides.min() < 1e-4 or sides.min() < 0.2 * sides.max():
        raise MrcheckError(f"{what}: corners do not form a square (sides {np.round(sides, 4).tolist()} m)", source)
    normal = np.cross(corners[1] - corners[0], corners[3] - corners[0])
    normal /= np.linalg.norm(normal)
    # a printed marker is flat: a corner off its plane is a typo in the survey
    if abs(np.dot(corners[2] - corners[0], normal)) > 0.05 * sides.max():
        raise MrcheckError(f"{what}: the four corners are not in one plane", source)


def _parse_board(k, entry, default_dictionary, source) -> Board:
    where = f"charuco board #{k}"
    if not isinstance(entry, dict):
        raise MrcheckError(f"{where} must be an object", source)
    name = entry.get("dictionary", default_dictionary)
    if name is None:
        raise MrcheckError(f"{where}: no 'dictionary'", source)
    squares = entry.get("squares")
    if (
        not isinstance(squares, list)
        or len(squares) != 2
        or not all(isinstance(s, int) and not isinstance(s, bool) and s >= 2 for s in squares)
    ):
        raise MrcheckError(f"{where}: 'squares' must be [columns, rows], whole numbers >= 2", source)
    square, marker = entry.get("square"), entry.get("marker")
    for key, value in (("square", square), ("marker", marker)):
        if problem := number_problem(value):  # an infinite square passed "marker < square"
            raise MrcheckError(f"{where}: {key}: {problem}", source)
    if not 0 < marker < square:
        raise MrcheckError(
            f"{where}: need 0 < marker < square (metres), got marker={marker!r}, square={square!r}", source
        )
    pose = entry.get("pose")
    if not isinstance(pose, dict):
        raise MrcheckError(f'{where}: \'pose\' must be {{"R": 3x3, "t": [x, y, z]}} (board-to-world)', source)
    R = _array(pose.get("R"), (3, 3), f"{where} pose R", source)
    t = _array(pose.get("t"), (3,), f"{where} pose t", source)
    if abs(np.linalg.det(R) - 1.0) > 1e-3 or not np.allclose(R @ R.T, np.eye(3), atol=1e-3):
        raise MrcheckError(f"{where}: pose R is not a rotation matrix", source)
    aruco = dictionary(name, source)
    n_markers = (squares[0] * squares[1]) // 2
    ids = entry.get("ids")
    if ids is None:
        ids = list(range(n_markers))
    if (
        not isinstance(ids, list)
        or len(ids) != n_markers
        or len(set(ids)) != n_markers
        or not all(isinstance(i, int) and 0 <= i < aruco.bytesList.shape[0] for i in ids)
    ):
        raise MrcheckError(
            f"{where}: needs {n_markers} distinct marker ids of {name} (0..{aruco.bytesList.shape[0] - 1})", source
        )
    try:
        board = cv2.aruco.CharucoBoard(tuple(squares), float(square), float(marker), aruco, np.asarray(ids, np.int32))
        board.setLegacyPattern(bool(entry.get("legacy", False)))
    except cv2.error as exc:
        raise MrcheckError(f"{where}: OpenCV refused the board ({exc.err})", source) from None
    return Board(k, name, board, R, t)


def _detector_parameters() -> cv2.aruco.DetectorParameters:
    params = cv2.aruco.DetectorParameters()
    # pose accuracy is limited by the corners: refine them to subpixel (default is none)
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    return params


def detect_markers(image: np.ndarray, marker_map: MarkerMap) -> Detection:
    """Find the map's markers and boards in ``image`` (grey or BGR uint8)."""
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
    detection = Detection()
    params = _detector_parameters()
    for name in marker_map.dictionaries:
        corners, ids, _ = cv2.aruco.ArucoDetector(dictionary(name), params).detectMarkers(grey)
        found = (
            {} if ids is None else {int(i): c.reshape(4, 2).astype(np.float64) for i, c in zip(ids.ravel(), corners)}
        )
        known = marker_map.markers.get(name, {})
        on_boards = set().union(*[b.marker_ids for b in marker_map.boards if b.dictionary == name])
        for marker_id in sorted(found):
            if marker_id in known:
                detection.groups.append(
                    Group({"id": marker_id, "dictionary": name}, found[marker_id], known[marker_id])
                )
            elif marker_id not in on_boards:
                detection.unknown.append({"id": marker_id, "dictionary": name})
        detection.unseen += [{"id": i, "dictionary": name} for i in sorted(set(known) - set(found))]

    for board in marker_map.boards:
        detector = cv2.aruco.CharucoDetector(board.board, cv2.aruco.CharucoParameters(), params)
        charuco_corners, charuco_ids, _, _ = detector.detectBoard(grey)
        if charuco_ids is None or len(charuco_ids) == 0:
            detection.unseen.append({"board": board.index, "dictionary": board.dictionary})
            continue
        ids = charuco_ids.ravel()
        detection.groups.append(
            Group(
                {"board": board.index, "dictionary": board.dictionary},
                charuco_corners.reshape(-1, 2).astype(np.float64),
                board.corners_world()[ids],
                atomic=False,
            )
        )
    return detection


__all__ = [
    "Board",
    "MarkerMap",
    "Group",
    "Detection",
    "dictionary",
    "load_marker_map",
    "parse_marker_map",
    "detect_markers",
]
