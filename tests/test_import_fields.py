"""What an IFC import knows about an element (GlobalId, name, class, storey) reaches the review's
hover pick and the discrepancy report."""

from __future__ import annotations

from pathlib import Path

from mrcheck.scene.model import load_scene

WALL = Path(__file__).parent / "data" / "cad" / "ifc" / "wall-standard-case.ifc"


def test_hover_pick_names_the_element():
    from mrcheck.apps.review.pick import Picker

    scene = load_scene(WALL)
    camera = scene.camera("overview", 320, 240)
    hit = Picker(scene).pick(camera, 160, 120)  # the overview looks at the wall's centre
    assert hit["instance"] == "0czCsOQ5z4dg8QGBRFInu2" and hit["ifc_class"] == "IfcWallStandardCase"


def test_discrepancy_report_carries_the_element(tmp_path):
    from mrcheck.apps.discrepancies.detector import detect
    from mrcheck.eval.discrepancy_eval import synthetic_photo

    scene = load_scene(WALL)
    camera = scene.camera("overview", 320, 240)
    result = detect(scene, camera, synthetic_photo(scene, camera))
    (suspect,) = result.suspects
    assert suspect.id == "0czCsOQ5z4dg8QGBRFInu2" and suspect.element["ifc_class"] == "IfcWallStandardCase"
    assert result.to_dict()["suspects"][0]["element"]["ifc_class"] == "IfcWallStandardCase"
    assert suspect.element_label == " (IfcWallStandardCase)"
