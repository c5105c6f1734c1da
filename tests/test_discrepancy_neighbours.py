"""A part next to a changed part is judged on the pixels only it explains (issue 41,
mrcheck.apps.discrepancies.neighbours): the claims of stronger suspects, and the one-way rule
that keeps both flags when each rests on the other's pixels."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from mrcheck.apps.discrepancies.neighbours import claimed_pixels, separate_neighbours


@dataclass
class S:  # the fields of a Suspect the separation reads
    id: str
    suspect: bool
    bbox: list
    best_shift: list
    explained_by: str | None = None


def _ids() -> np.ndarray:
    """Three parts side by side in a 20 x 60 image: a (x 5-14), b (x 17-26), c (x 45-54)."""
    ids = np.full((20, 60), -1)
    ids[5:15, 5:15], ids[5:15, 17:27], ids[5:15, 45:55] = 0, 1, 2
    return ids


INDEX = {"a": 0, "b": 1, "c": 2}
BOXES = {"a": [5, 5, 14, 14], "b": [17, 5, 26, 14], "c": [45, 5, 54, 14]}


def _suspects(*names) -> list:
    return [S(n, True, BOXES[n], [0, 0]) for n in names]


def _rescore(holds: dict):
    """A rescore that says whether a part's flag holds outside the claimed pixels: ``holds[name]``
    is the part's verdict whenever its own pixels are touched by the claim."""

    def rescore(index, claimed, s):
        touched = (claimed & (_ids() == index)).any() or (claimed & claimed_pixels(_ids() == index, [0, 0], 3)).any()
        return replace(s, suspect=holds.get(s.id, True) if touched else True)

    return rescore


def test_claimed_pixels_cover_the_part_its_shifted_image_and_the_reach():
    inside = np.zeros((20, 30), bool)
    inside[5:10, 5:10] = True
    claim = claimed_pixels(inside, [6, 0], 2)
    assert claim[7, 3] and claim[7, 17] and not claim[7, 19] and not claim[0, 7]  # x 3 .. 17 (5 - 2, 15 + 2)


def test_a_flag_that_rests_on_a_stronger_neighbours_pixels_is_explained_by_it():
    out = separate_neighbours(_suspects("a", "b", "c"), INDEX, _ids(), _rescore({"b": False}), 3)
    by = {s.id: (s.suspect, s.explained_by) for s in out}
    assert by == {"a": (True, None), "b": (False, "a"), "c": (True, None)}
    assert [s.id for s in out] == ["a", "b", "c"]  # the ranking kept


def test_flags_that_rest_on_each_other_both_stay():
    out = separate_neighbours(_suspects("a", "b"), INDEX, _ids(), _rescore({"a": False, "b": False}), 3)
    assert all(s.suspect and s.explained_by is None for s in out)


def test_a_part_apart_from_every_claim_keeps_its_flag():
    out = separate_neighbours(_suspects("a", "c"), INDEX, _ids(), _rescore({"c": False}), 3)
    assert all(s.suspect for s in out)  # c is 30 px from a: a's change cannot explain it


def test_parts_not_flagged_pass_through():
    quiet = [S("a", False, BOXES["a"], [0, 0]), *_suspects("b")]
    out = separate_neighbours(quiet, INDEX, _ids(), _rescore({}), 3)
    assert [(s.id, s.suspect, s.explained_by) for s in out] == [("a", False, None), ("b", True, None)]
