"""Suggested markers from ``mrcheck discrepancies`` runs, imported into a review.

``mrcheck review TARGET --suggestions OUTDIR/suspects.json`` (repeatable; ``NAME=FILE`` names
the shot explicitly) adds each of the run's ``suggested_markers`` to its shot as an ordinary
marker of category ``suggested`` whose note carries the detector's guess and score, so the
planner keeps (re-categorises), moves, edits or deletes it like any other. The shot of a file
without ``NAME=`` is the review shot with the same photo file. Every suggestion is imported
once per review: restarting the server does not bring back one the planner deleted, and a
re-run of ``mrcheck discrepancies`` (other notes, scores, positions) does not add its parts
again. A suggestion is known by its shot and CAD part (instance), or, for photo structure no
part explains, by its shot and position: within 2 % of the photo's width of an imported one.
"""

from __future__ import annotations

import math
from pathlib import Path

from mrcheck.apps.review.storage import SEVERITIES
from mrcheck.core.camerafiles import load_shot
from mrcheck.core.errors import MrcheckError
from mrcheck.core.inputs import real_path
from mrcheck.core.jsonfile import number_problem, read_json

CATEGORY = "suggested"
REGION_NEAR = 0.02  # a part-less suggestion this close (share of the photo's width) to an imported one is that one


def _made_on(doc: dict):
    """The camera and photo of the shot the run was made on, or None when it cannot be opened
    (moved or deleted since)."""
    try:
        return load_shot(doc["shot"])
    except (KeyError, TypeError, MrcheckError):
        return None


def _shot_of(source, spec: str, made_on, path: Path):
    name, sep, _ = spec.partition("=")
    if sep:
        if name not in source.shots:
            raise MrcheckError(f"no shot named {name!r} in the review (have: {', '.join(source.shots)})", path)
        return source.shots[name]
    if made_on is None:
        raise MrcheckError("cannot open the shot this file was made from; pass NAME=FILE", path)
    photo = real_path(made_on[1])
    same = [shot for shot in source.shots.values() if real_path(shot.photo) == photo]
    if len(same) > 1:
        raise MrcheckError(f"its photo is the photo of shots {', '.join(s.name for s in same)}; pass NAME=FILE", path)
    if not same:
        raise MrcheckError("its photo is not one of the review's shots; pass NAME=FILE", path)
    return same[0]


def _check_size(shot, made_on, doc: dict, suggested: list, path: Path) -> None:
    """The run's markers are in the native pixels of the shot it was made on: refuse a run on a
    photo of another size (its markers would land elsewhere, or outside the image)."""
    w, h = shot.camera.width, shot.camera.height
    if made_on is not None and (made_on[0].width, made_on[0].height) != (w, h):
        raise MrcheckError(
            f"made on a {made_on[0].width}x{made_on[0].height} shot ({doc['shot']}), but shot {shot.name!r} is {w}x{h}",
            path,
        )
    # without the shot it was made on, the markers themselves are all there is to check
    for m in suggested:
        if not (0 <= m["x"] < w and 0 <= m["y"] < h):
            raise MrcheckError(
                f"a suggested marker at ({m['x']:g}, {m['y']:g}) lies outside shot {shot.name!r} "
                f"({w}x{h}): made on another photo?",
                path,
            )


def suggestions_file(spec: str) -> Path:
    """The file of a ``FILE`` or ``NAME=FILE`` spec."""
    return Path(spec.partition("=")[2] or spec)


def load_suggestions(source, specs) -> dict:
    """{shot name: [marker dicts in the photo's pixels, with their import key]} from ``FILE`` or
    ``NAME=FILE`` specs."""
    out = {}
    for spec in specs:
        path = suggestions_file(spec)
        doc = read_json(path, "suggestions")  # not found, a symlink loop, empty, malformed: says which
        try:
            suggested = doc["suggested_markers"]
            if not isinstance(suggested, list):
                raise TypeError
        except (KeyError, TypeError):
            raise MrcheckError("not a suspects.json of mrcheck discrepancies (no suggested_markers)", path) from None
        suggested = [_checked(m, i, path) for i, m in enumerate(suggested)]
        made_on = _made_on(doc)  # read once: it names the shot and says which size the markers are in
        shot = _shot_of(source, spec, made_on, path)
        _check_size(shot, made_on, doc, suggested, path)
        # the detector worked on the photo's native pixels, as the review's markers are
        sx, sy = shot.served_scale()
        for m in suggested:
            note = f"{m['category']}? {m['note']}".strip()
            key = f"part:{m['part']}" if m["part"] else f"region:{m['x']:.1f},{m['y']:.1f}"
            out.setdefault(shot.name, []).append(
                {
                    "x": m["x"],
                    "y": m["y"],
                    "category": CATEGORY,
                    "severity": m["severity"],
                    "part": m["part"],
                    "distance": None,
                    "mode": None,
                    "note": note,
                    "key": key,
                    # what reviews of before (database version 0) recorded: served pixels and the note
                    "legacy_key": f"{m['x'] * sx:.1f},{m['y'] * sy:.1f},{note}",
                }
            )
    return out


def _checked(m, index: int, path: Path) -> dict:
    """A suggested marker's fields, checked: one line naming the file and the marker (from 1)."""

    def fail(problem):
        raise MrcheckError(f"suggested marker {index + 1}: {problem}", path)

    if not isinstance(m, dict):
        fail("must be an object with x, y")
    for key in ("x", "y"):
        if problem := number_problem(m.get(key)):
            fail(f"{key} (photo pixels): {problem}")
    severity = m.get("severity", 2)
    if severity not in SEVERITIES or isinstance(severity, (bool, float)):
        fail(f"severity must be 1, 2 or 3, got {severity!r}")
    texts = {k: m.get(k, default) for k, default in (("category", "other"), ("note", ""), ("part", None))}
    for key, value in texts.items():
        if not (isinstance(value, str) or (key == "part" and value is None)):
            fail(f"{key} must be a string, got {value!r}")
    return {"x": float(m["x"]), "y": float(m["y"]), "severity": severity, **texts}


def pending(suggestions: list, imported: set, width: int) -> list:
    """The suggestions of one shot (``width`` px wide) that are not in ``imported`` (the keys
    recorded by earlier imports): by part, or by position for photo structure no part explains
    (a re-run moves a region's centre a little), or by the key of a review of before."""
    regions = [tuple(map(float, k.removeprefix("region:").split(","))) for k in imported if k.startswith("region:")]
    near = REGION_NEAR * width

    def seen(s):
        if s["key"] in imported or s["legacy_key"] in imported:
            return True
        return s["key"].startswith("region:") and any(math.hypot(s["x"] - x, s["y"] - y) <= near for x, y in regions)

    return [s for s in suggestions if not seen(s)]
