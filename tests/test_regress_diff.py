"""``mrcheck regress diff``: every change of known revision pairs found, nothing else reported.

Pairs with known truth: five as-built variants of the sample cell (``scene asbuilt`` writes
what it changed), the IFC house of tests/ifc_house.py with a wall moved, a door deleted and a
column added, and buildingSMART's wall-standard-case.ifc (from ``../shared/data/cad/ifc``) with
its wall turned and moved and a column added (tests/ifc_revisions.py makes the edits).
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from mrcheck.apps.bcf import read_bcf_file
from mrcheck.apps.modeldiff import diff_scenes
from mrcheck.apps.modeldiff.compare import compare_pair, rigid_fit, rotation_angle_axis
from mrcheck.apps.modeldiff.elements import Element
from mrcheck.apps.modeldiff.picture import COLOURS
from mrcheck.apps.modeldiff.revisions import load_revision
from mrcheck.cli import main
from mrcheck.core.images import read_image
from mrcheck.core.resources import sample_scene_path
from mrcheck.eval.realdata import real_root
from mrcheck.scene.asbuilt import make_asbuilt
from mrcheck.scene.model import load_scene, make_part

from .ifc_house import build_house
from .ifc_revisions import edit_house, edit_wall_file, house_with_door
from .step_revisions import shift_solid

TRUTH_KINDS = {
    "moved": "moved",
    "rotated": "moved",
    "missing": "removed",
    "added": "added",
    "replaced": "changed geometry",
}
WALL_FILE = real_root().parent / "cad" / "ifc" / "wall-standard-case.ifc"


def _turn_z(deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _element(part, matrix, id_="e") -> Element:
    return Element(id_, part, np.asarray(matrix, np.float64), id_, None)


@pytest.fixture(scope="module")
def box_part():
    corners = np.array([[x, y, z] for x in (0, 2.0) for y in (0, 1.0) for z in (0, 0.5)], np.float64)
    faces = np.array([[0, 1, 2], [1, 3, 2], [4, 5, 6], [5, 7, 6]])
    return make_part("box", "test", corners, faces, np.eye(4))


def test_rigid_fit_finds_the_rotation():
    points = np.random.default_rng(1).normal(size=(8, 3))
    rotation, residual = rigid_fit(points, points @ _turn_z(33.0).T + 5.0)
    angle, axis = rotation_angle_axis(rotation)
    assert residual < 1e-9
    assert angle == pytest.approx(33.0, abs=1e-9)
    assert axis == pytest.approx([0, 0, 1], abs=1e-9)


@pytest.mark.parametrize(
    ("turn_deg", "shift", "scale", "kind"),
    [
        (0.0, (0.0, 0.0, 0.0), 1.0, "unchanged"),
        (0.0, (0.0009, 0.0, 0.0), 1.0, "unchanged"),  # under the 1 mm tolerance
        (0.05, (0.0, 0.0, 0.0), 1.0, "unchanged"),  # under 0.1 degrees (its corners move < 1 mm)
        (0.0, (0.002, 0.0, 0.0), 1.0, "moved"),
        (0.2, (0.0, 0.0, 0.0), 1.0, "moved"),
        (30.0, (1.0, -2.0, 0.0), 1.0, "moved"),
        (0.0, (0.0, 0.0, 0.0), 1.01, "changed geometry"),  # 2 cm longer: not a rigid motion
    ],
)
def test_pair_kinds_and_tolerances(box_part, turn_deg, shift, scale, kind):
    old = np.eye(4)
    old[:3, 3] = (4.0, 1.0, 0.0)
    new = old.copy()
    new[:3, :3] = _turn_z(turn_deg) * scale
    new[:3, 3] += shift
    change = compare_pair(_element(box_part, old), _element(box_part, new), 0.001, 0.1)
    assert change.kind == kind
    if kind == "moved":
        assert change.rotation_deg == pytest.approx(turn_deg, abs=1e-3)
        assert change.offset_m == pytest.approx(shift, abs=1e-6)  # the box turns about its centre


def test_a_changed_mesh_is_changed_geometry(box_part):
    other = make_part("box", "test", box_part.vertices.astype(np.float64) * 1.1, box_part.faces, np.eye(4))
    change = compare_pair(_element(box_part, np.eye(4)), _element(other, np.eye(4)), 0.001, 0.1)
    assert change.kind == "changed geometry"


@pytest.fixture(scope="module")
def cell():
    return load_scene(sample_scene_path())


@pytest.mark.parametrize("seed", range(5))
def test_asbuilt_pairs_every_change_found_nothing_else(cell, tmp_path, seed):
    manifest, truth_file = make_asbuilt(sample_scene_path(), tmp_path / f"built{seed}", seed=seed)
    truth = json.loads(truth_file.read_text())["discrepancies"]
    diff = diff_scenes(cell, load_scene(manifest))
    found = {c.id: c for c in diff.changes}
    assert {c.id: c.kind for c in diff.changes} == {t["id"]: TRUTH_KINDS[t["kind"]] for t in truth}
    for t in truth:
        change = found[t["id"]]
        if t["kind"] == "moved":
            assert change.offset_m == pytest.approx(t["detail"]["vector"], abs=1e-4)
            assert change.rotation_deg == pytest.approx(0.0, abs=1e-3)
        if t["kind"] == "rotated":
            assert change.rotation_deg == pytest.approx(t["magnitude"], abs=0.01)
            assert change.axis == pytest.approx([0, 0, np.sign(t["detail"]["angle_deg"])], abs=1e-6)


@pytest.fixture(scope="module")
def house_pair(tmp_path_factory):
    folder = tmp_path_factory.mktemp("house")
    build_house(folder / "house.ifc")
    door = house_with_door(folder / "house.ifc", folder / "week48.ifc")
    edits = edit_house(folder / "week48.ifc", folder / "week49.ifc")
    assert edits["removed"] == door
    return folder, edits


def _rows(report: Path) -> list[dict]:
    with (report / "changes.csv").open(newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.slow
def test_ifc_house_revision_reports_exactly_its_edits(house_pair, capsys):
    folder, edits = house_pair
    report = folder / "report"
    code = main(["regress", "diff", str(folder / "week48.ifc"), str(folder / "week49.ifc"), "--bcf", "-o", str(report)])
    assert code == 1  # changes found
    rows = [r for r in _rows(report) if r["kind"] != "unchanged"]
    assert {r["kind"]: r["ifc_globalid"] for r in rows} == edits
    assert len(rows) == 3
    moved = next(r for r in rows if r["kind"] == "moved")
    assert [float(moved[f"offset_{a}_m"]) for a in "xyz"] == pytest.approx([0.5, 0.0, 0.0], abs=1e-4)
    assert float(moved["rotation_deg"]) == pytest.approx(0.0, abs=1e-3)
    assert "1 added, 1 removed, 1 moved, 0 changed geometry" in capsys.readouterr().out
    topics = read_bcf_file(report / "changes.bcfzip")
    assert sorted(c.ifc_guid for t in topics for c in t.components) == sorted(edits.values())
    picture = read_image(report / "view-overview.png")
    for kind in ("added", "removed", "moved"):  # each change shows in its colour
        assert _has_colour(picture, COLOURS[kind]), kind


def _has_colour(image: np.ndarray, colour, min_pixels: int = 30) -> bool:
    """Pixels of the colour's hue (any brightness: the tint follows the AO, ghosts are blended)."""
    rgb = image[..., :3].astype(np.float64)
    chroma = rgb - rgb.mean(axis=2, keepdims=True)
    direction = chroma / (np.linalg.norm(chroma, axis=2, keepdims=True) + 1e-9)
    target = np.asarray(colour, np.float64) - np.mean(colour)
    want = target / np.linalg.norm(target)
    saturated = np.ptp(rgb, axis=2) > 40
    return int(((direction @ want > 0.97) & saturated).sum()) >= min_pixels


@pytest.mark.skipif(not WALL_FILE.is_file(), reason=f"no shared CAD data here ({WALL_FILE})")
def test_real_ifc_wall_turned_and_moved_column_added(tmp_path):
    offset, angle = np.array([0.25, -0.4, 0.0]), 15.0
    edits = edit_wall_file(WALL_FILE, tmp_path / "next.ifc", offset, angle)
    old, new = load_scene(WALL_FILE), load_scene(tmp_path / "next.ifc")
    diff = diff_scenes(old, new)
    assert {c.kind: c.global_id for c in diff.changes} == edits
    moved = next(c for c in diff.changes if c.kind == "moved")
    assert moved.rotation_deg == pytest.approx(angle, abs=1e-3)
    # the wall turns about its placement's origin: its centre goes to R (c - p) + p + offset
    import ifcopenshell
    import ifcopenshell.util.placement

    wall = ifcopenshell.open(str(WALL_FILE)).by_guid(moved.id)
    origin = np.array(ifcopenshell.util.placement.get_local_placement(wall.ObjectPlacement))[:3, 3] / 1000.0
    centre = np.array(moved.old_centre)
    expected = _turn_z(angle) @ (centre - origin) + origin + offset
    assert moved.new_centre == pytest.approx(expected, abs=1e-4)


def test_same_revision_exits_0_with_every_element_unchanged(tmp_path):
    scene = str(sample_scene_path())
    code = main(["regress", "diff", scene, scene, "--no-pictures", "-o", str(tmp_path / "r")])
    assert code == 0
    rows = _rows(tmp_path / "r")
    assert rows and {r["kind"] for r in rows} == {"unchanged"}
    assert not list((tmp_path / "r").glob("*.png"))


@pytest.mark.parametrize(
    "args",
    [
        ["regress", "diff", "missing.ifc", "{scene}", "-o", "{out}"],
        ["regress", "diff", "{scene}", "{scene}", "--width", "0", "-o", "{out}"],
        ["regress", "diff", "{scene}", "{scene}", "--view", "nowhere", "-o", "{out}"],
        ["regress", "diff", "{scene}", "{glb}", "-o", "{out}"],
    ],
)
def test_bad_input_one_line_exit_2_nothing_written(tmp_path, capsys, args):
    out = tmp_path / "r"
    (tmp_path / "broken.glb").write_bytes(b"glTF\x02\x00\x00\x00 not really")
    code = main([a.format(scene=sample_scene_path(), out=out, glb=tmp_path / "broken.glb") for a in args])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists() or not any(p.name != ".mrcheck-output" for p in out.iterdir())


def test_no_change_no_tint(tmp_path):
    """A revision against itself: the picture is the grey render and the legend, no change colour."""
    scene = str(sample_scene_path())
    assert main(["regress", "diff", scene, scene, "--view", "overview", "--width", "320", "-o", str(tmp_path)]) == 0
    picture = read_image(tmp_path / "view-overview.png")[:-30]  # without the legend strip
    assert not any(_has_colour(picture, colour, min_pixels=1) for colour in COLOURS.values())


def test_an_input_is_never_overwritten(tmp_path, capsys):
    (tmp_path / "changes.csv").write_text("x")  # an input that is also an output's name
    scene = str(sample_scene_path())
    code = main(["regress", "diff", scene, str(tmp_path / "changes.csv"), "-o", str(tmp_path)])
    assert code == 2
    assert (tmp_path / "changes.csv").read_text() == "x"


def _glb(path: Path, nodes) -> Path:
    """A glTF file of ``nodes``: (name, mesh name, trimesh mesh, translation); repeated names
    are written as repeated names (trimesh's writer would number them, so they are renamed in
    the file's JSON afterwards: ``NAME~`` -> ``NAME``)."""
    import trimesh

    scene = trimesh.Scene()
    for name, mesh_name, mesh, at in nodes:
        scene.add_geometry(
            mesh, node_name=name, geom_name=mesh_name, transform=trimesh.transformations.translation_matrix(at)
        )
    data = scene.export(file_type="glb")
    path.write_bytes(data.replace(b'~"', b'" '))  # same length (JSON allows the space): chunk sizes stay right
    return path


def test_glb_revisions_by_node_path_with_repeated_names(tmp_path):
    import trimesh

    box, post = trimesh.creation.box((1, 1, 1)), trimesh.creation.cylinder(0.2, 2.0)
    floor = ("floor", "floor", trimesh.creation.box((10, 10, 0.1)), (0, 0, -0.05))
    old = _glb(
        tmp_path / "old.glb",
        [
            floor,
            ("rack", "box", box, (0, 0, 0.5)),
            ("rack~", "box", box, (3, 0, 0.5)),
            ("post", "post", post, (0, 3, 1)),
        ],
    )
    new = _glb(
        tmp_path / "new.glb",
        [
            floor,
            ("rack", "box", box, (0, 0, 0.5)),
            ("rack~", "box", box, (3.4, 0, 0.5)),
            ("cab", "cab", box, (-3, -3, 0.5)),
        ],
    )
    code = main(["regress", "diff", str(old), str(new), "--no-pictures", "-o", str(tmp_path / "r")])
    assert code == 1
    rows = {r["id"]: r for r in _rows(tmp_path / "r")}
    # the second "rack" is "rack_1" (trimesh numbers repeated names in file order) in both revisions
    assert {i: r["kind"] for i, r in rows.items()} == {
        "cab": "added",
        "post": "removed",
        "rack_1": "moved",
        "rack": "unchanged",
        "floor": "unchanged",
    }
    assert float(rows["rack_1"]["offset_x_m"]) == pytest.approx(0.4, abs=1e-6)


def test_a_shape_baked_into_its_mesh_moved_is_moved_not_changed(tmp_path):
    """An exporter that writes world coordinates into the mesh (no node transform): the same
    faces at rigidly moved vertices are a move, with its offset and angle; stretched, a change."""
    import trimesh

    def placed(mesh, turn_deg, at):
        matrix = np.eye(4)
        matrix[:3, :3], matrix[:3, 3] = _turn_z(turn_deg), at
        return mesh.copy().apply_transform(matrix)

    cabinet, bench = trimesh.creation.box((0.6, 0.4, 1.8)), trimesh.creation.box((2.0, 0.8, 0.9))
    old = _glb(
        tmp_path / "old.glb",
        [("cab", "cab", placed(cabinet, 0, (1, 1, 0.9)), (0, 0, 0)), ("bench", "bench", bench, (0, 0, 0))],
    )
    stretched = bench.copy().apply_scale((1.1, 1.0, 1.0))
    new = _glb(
        tmp_path / "new.glb",
        [("cab", "cab", placed(cabinet, 30, (1.5, 1, 0.9)), (0, 0, 0)), ("bench", "bench", stretched, (0, 0, 0))],
    )
    diff = diff_scenes(load_revision(old), load_revision(new))
    rows = {c.id: c for c in diff.rows}
    assert rows["cab"].kind == "moved" and rows["bench"].kind == "changed geometry"
    assert rows["cab"].rotation_deg == pytest.approx(30.0, abs=1e-3)
    assert rows["cab"].offset_m == pytest.approx((0.5, 0.0, 0.0), abs=1e-5)  # its centre, turned in place


def test_step_solid_moved_in_its_own_coordinates_is_moved(tmp_path):
    """tests/data's red cube and blue cylinder (two solids, no assembly): the cylinder's points
    shifted 20 mm along x in the file; ids are the STEP import's names."""
    source = Path(__file__).parent / "data" / "cad" / "step" / "red_cube_blue_cylinder.step"
    shift_solid(source, tmp_path / "next.step", "blue_cylinder", (0.02, 0.0, 0.0))  # the file is in metres
    diff = diff_scenes(load_scene(source), load_scene(tmp_path / "next.step"))
    assert {c.id: c.kind for c in diff.rows} == {"blue_cylinder": "moved", "red_cube": "unchanged"}
    assert diff.changes[0].offset_m == pytest.approx((0.02, 0.0, 0.0), abs=1e-6)
    assert diff.changes[0].rotation_deg == pytest.approx(0.0, abs=1e-3)
