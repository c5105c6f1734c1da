"""A part next to a changed part is judged on the pixels only it explains (issue 41).

A moved, missing or replaced part disturbs the photo around its planned place and around where
it went: it hides a neighbour's outline there, or uncovers structure beside it. A neighbour
scored on its whole outline is then flagged for its neighbour's change. So the flagged parts are
taken in the order of the evidence against them, the outline pixels the photo does not show
where planned (a machine moved off its place before the thin post it uncovered, whatever their
scores); each one accepted *claims* the pixels its change can disturb:
its planned image and its image at its best shift, grown by the reach of the shifted-outline
search (:func:`~mrcheck.apps.discrepancies.thresholds.shift_radius`, 4 tolerances). A weaker
flagged part is scored again on its outline outside the pixels claimed so far; it stays a
suspect only when that outline alone is large enough to judge and still scores as a suspect.
Otherwise it is kept, unflagged, with ``explained_by`` naming the part whose change explains it.

Measured on held-out seeds 760-769 (docs/discrepancy-evaluation.md): flags on unchanged parts
next to a change 70 -> 47 (mrcheck's photos), 81 -> 57 (Open3D's); target recall 172 -> 165
and 161 -> 160 of about 230.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import cv2
import numpy as np


def claimed_pixels(inside: np.ndarray, shift, reach: int) -> np.ndarray:
    """(H, W) bool: the planned image ``inside`` of a flagged part and the same image moved by its
    best ``shift`` (dx, dy), grown by ``reach`` px: where its change can disturb the photo."""
    dx, dy = int(shift[0]), int(shift[1])
    moved = np.zeros_like(inside)
    h, w = inside.shape
    moved[max(0, dy) : h + min(0, dy), max(0, dx) : w + min(0, dx)] = inside[
        max(0, -dy) : h + min(0, -dy), max(0, -dx) : w + min(0, -dx)
    ]
    grown = (inside | moved).astype(np.uint8)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * reach + 1, 2 * reach + 1))
    return cv2.dilate(grown, kernel).astype(bool)


def separate_neighbours(suspects: list, index_of: dict, ids: np.ndarray, rescore: Callable, reach: int) -> list:
    """``suspects`` with the flags a neighbour's change explains taken off (module docstring).
    ``index_of``: instance id -> index in ``ids``; ``rescore(index, claimed, suspect)``: the
    suspect scored on its outline outside ``claimed`` (None: too little of it left to judge).
    A flag is explained away only one way: when the neighbour's flag also rests on the pixels
    the part would claim, neither explains the other and both stay. (Unexplained regions claim
    nothing: on a cluttered desk their boxes cover every object.)"""
    claimed, accepted, out = np.zeros(ids.shape, bool), [], []
    for s in suspects:
        if not s.suspect:
            out.append(s)
            continue
        index = index_of[s.id]
        own_claim = claimed_pixels(ids == index, s.best_shift, reach)
        if claimed.any() and not _stands_alone(rescore(index, claimed, s)):
            by = _explained_by(s, own_claim, accepted, index_of, rescore)
            if by is not None:
                out.append(replace(s, suspect=False, explained_by=by))
                continue
        claimed |= own_claim
        accepted.append((s, own_claim))
        out.append(s)
    rank = {s.id: k for k, s in enumerate(suspects)}
    return sorted(out, key=lambda s: rank[s.id])  # in the ranking they came in


def _stands_alone(rescored) -> bool:
    return rescored is not None and rescored.suspect


def _explained_by(s, own_claim, accepted, index_of, rescore) -> str | None:
    """Who explains ``s``'s flag: the nearest accepted suspect next to it whose own flag does not
    rest on ``s``'s pixels; None when every neighbour's flag needs ``s``'s pixels too (mutual:
    both stay)."""
    touching = [a for a, claim in accepted if (claim & own_claim).any()]
    independent = [a for a in touching if _stands_alone(rescore(index_of[a.id], own_claim, a))]
    return _claimant(independent, s) if independent else None


def _claimant(flagged: list, s) -> str:
    """The suspect of ``flagged`` nearest ``s`` (box centres): the change that explains its flag."""

    def centre(box) -> np.ndarray:
        return np.array([(box[0] + box[2]) / 2, (box[1] + box[3]) / 2])

    return min(flagged, key=lambda a: float(np.sum((centre(a.bbox) - centre(s.bbox)) ** 2))).id


__all__ = ["claimed_pixels", "separate_neighbours"]
