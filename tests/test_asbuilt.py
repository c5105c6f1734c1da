"""``mrcheck scene asbuilt``: the as-built variant is deterministic, self-contained, and its
``discrepancies.json`` says exactly what differs from the planned scene -- checked here against
the geometry both scenes load to, instance by instance (matched by id)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import trimesh

from mrcheck.cli import main
from mrcheck.core.errors import MrcheckError
from mrcheck.core.resources import sample_scene_path
from mrcheck.scene import asbuilt
from mrcheck.scene.asbuilt import KINDS, make_asbuilt
from mrcheck.scene.model import load_scene

SAMPLE = sample_scene_path()
TOL = 1e-6  # of values the variant computes (written with 9 decimals)
EXACT = 1e-9  # of values it copies


# -- the check of a variant against its plan -----------------------------------------------------
def _instances(scene) -> dict:
    """{instance id: (part, transform, world box)}."""
    found = {}
    for part in scene.parts:
        for iid, T, box in zip(part.instance_ids, part.transforms, part.instance_bounds()):
            assert iid not in found, f"instance id {iid} twice"
            found[iid] = (part, T, box)
    return found


def _rz(deg) -> np.ndarray:
    a = np.radians(deg)
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])


def _about(pivot, linear) -> np.ndarray:
    """The 4x4 map x -> pivot + linear (x - pivot)."""
    M = np.eye(4)
    M[:3, :3] = linear
    M[:3, 3] = np.asarray(pivot) - linear @ np.asarray(pivot)
    return M


def _base(box) -> np.ndarray:
    return np.array([(box[0, 0] + box[1, 0]) / 2, (box[0, 1] + box[1, 1]) / 2, box[0, 2]])


def check_variant(planned_path, outdir) -> dict:
    """Every listed discrepancy against the transforms both scenes load to, and every instance
    not listed unchanged; returns the report."""
    report = json.loads((Path(outdir) / "discrepancies.json").read_text())
    planned, built = load_scene(planned_path), load_scene(Path(outdir) / "scene.toml")
    before, after = _instances(planned), _instances(built)
    listed = {}
    for d in report["discrepancies"]:
        assert d["id"] not in listed, f"{d['id']} listed twice"
        listed[d["id"]] = d
        assert d["kind"] in KINDS and set(d) == {"id", "part", "kind", "magnitude", "unit", "detail"}
        kind, mag = d["kind"], d["magnitude"]
        if kind == "missing":
            assert d["id"] in before and d["id"] not in after and mag is None and d["unit"] is None
            continue
        part, T, box = after[d["id"]]
        if kind == "added":
            assert d["id"] not in before and mag is None and d["unit"] is None
            template_part, T0, box0 = before[d["detail"]["template"]]
            assert part.name == d["part"] == template_part.name
            assert np.allclose(T[:3, :3], T0[:3, :3], atol=EXACT)  # a copy, shifted horizontally
            assert abs(T[2, 3] - T0[2, 3]) < EXACT
            assert np.allclose(_base(box), d["detail"]["position"], atol=TOL)
            assert abs(box[0, 2] - box0[0, 2]) < TOL  # on the floor like its template
            continue
        old_part, T0, box0 = before[d["id"]]
        assert d["part"] == old_part.name
        assert abs(box[0, 2] - box0[0, 2]) < TOL  # no base goes up or down: nothing floats, nothing sinks
        if kind == "moved":
            shift = T[:3, 3] - T0[:3, 3]
            assert np.allclose(T[:3, :3], T0[:3, :3], atol=EXACT) and abs(shift[2]) < EXACT
            assert np.allclose(shift, d["detail"]["vector"], atol=TOL)
            assert abs(np.linalg.norm(shift) - mag) < TOL and d["unit"] == "m" and 0.05 <= mag <= 2.0
            assert part.name == old_part.name
        elif kind == "rotated":
            turn = T[:3, :3] @ np.linalg.inv(T0[:3, :3])
            angle = np.degrees(np.arctan2(turn[1, 0], turn[0, 0]))
            assert np.allclose(turn, _rz(angle), atol=TOL)  # about the vertical axis
            assert abs(angle - d["detail"]["angle_deg"]) < TOL and abs(abs(angle) - mag) < TOL
            assert d["unit"] == "deg" and 5.0 <= mag <= 90.0
            assert np.allclose(T, _about(d["detail"]["pivot"], _rz(angle)) @ T0, atol=TOL)
            assert part.name == old_part.name
        elif kind == "replaced":
            assert d["unit"] is None and 0.7 <= mag <= 1.4 and abs(mag - 1.0) >= 0.1 - EXACT
            assert np.allclose(T, _about(d["detail"]["pivot"], mag * np.eye(3)) @ T0, atol=TOL)
            assert np.allclose(_base(box), d["detail"]["pivot"], atol=TOL)  # scaled about its base
            assert part.name == d["detail"]["new_part"] != old_part.name
            assert np.array_equal(part.vertices, old_part.vertices)  # same mesh, other size
    for iid, (part, T0, _) in before.items():
        if iid not in listed:
            new_part, T, _ = after[iid]
            assert new_part.name == part.name and np.allclose(T, T0, rtol=0, atol=EXACT), f"{iid} changed unlisted"
    added = {i for i, d in listed.items() if d["kind"] == "added"}
    missing = {i for i, d in listed.items() if d["kind"] == "missing"}
    assert set(after) == (set(before) - missing) | added
    return report


def _overlap(a, b, tol=0.01) -> bool:
    return bool(np.all(np.minimum(a[1], b[1]) - np.maximum(a[0], b[0]) > tol))


# -- scenes ---------------------------------------------------------------------------------------
def box_file(path: Path, size, lift=True) -> Path:
    """A box mesh file standing on z = 0 (``lift``) around the origin."""
    z = size[2] / 2 if lift else 0.0
    path.parent.mkdir(parents=True, exist_ok=True)
    trimesh.creation.box(size, trimesh.transformations.translation_matrix((0, 0, z))).export(path)
    return path


def small_scene(folder: Path, extra: str = "") -> Path:
    """A 20 x 20 m ground slab (named so no word excludes it: its footprint does), crates in
    .stl and .glb, a machine in mm, a part placed with matrix instances and a wall."""
    box_file(folder / "meshes" / "ground.glb", (20, 20, 0.2), lift=False)
    box_file(folder / "meshes" / "crate.stl", (1.0, 0.8, 0.6))
    box_file(folder / "meshes" / "machine.glb", (2000, 1500, 1800))  # millimetres
    box_file(folder / "meshes" / "wall.glb", (20, 0.2, 3))
    crates = ", ".join(f"{{ translate = [{x}.0, {y}.0, 0.0] }}" for x in (-6, -3, 0, 3, 6) for y in (-6, 0))
    (folder / "scene.toml").write_text(f"""format = 1
name = "small"

[[parts]]
name = "ground"
mesh = "meshes/ground.glb"
units = "m"
translate = [0.0, 0.0, -0.1]

[[parts]]
name = "crate"
mesh = "meshes/crate.stl"
units = "m"
color = [0.6, 0.4, 0.2]
instances = [{crates}]

[[parts]]
name = "machine"
mesh = "meshes/machine.glb"
units = "mm"
translate = [0.0, 5.0, 0.0]
rotate_deg = [0.0, 0.0, 30.0]

[[parts]]
name = "rack"
mesh = "meshes/crate.stl"
units = "m"
instances = [
    {{ id = "rack-A", matrix = [[0.0, -1.0, 0.0, -8.0], [1.0, 0.0, 0.0, 7.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]] }},
    {{ id = "rack-B", matrix = [[1.0, 0.0, 0.0, 8.0], [0.0, 1.0, 0.0, 7.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]] }},
]

[[parts]]
name = "north_wall"
mesh = "meshes/wall.glb"
units = "m"
translate = [0.0, 9.9, 0.0]
{extra}
[[viewpoints]]
name = "overview"
eye = [-9.0, -9.0, 1.7]
target = [0.0, 0.0, 0.5]
""")
    return folder / "scene.toml"


@pytest.fixture(scope="module")
def sample_variant(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("asbuilt") / "seed0"
    make_asbuilt(SAMPLE, out, seed=0)
    return out


# -- the tests -------------------------------------------------------------------------------------
def test_sample_variant_has_every_kind_within_range_and_matches_the_geometry(sample_variant):
    report = check_variant(SAMPLE, sample_variant)
    kinds = [d["kind"] for d in report["discrepancies"]]
    assert set(kinds) == set(KINDS)
    n_instances = sum(len(p.transforms) for p in load_scene(SAMPLE).parts)
    assert len(kinds) == round(0.1 * n_instances)  # about 10 %: 8 of 76
    assert report["planned"] == str(SAMPLE.resolve()) and report["seed"] == 0
    excluded = {e["part"]: e["reason"] for e in report["excluded_parts"]}
    assert excluded["floor"] == "largest footprint" and {"back_wall", "column", "hall_beam"} <= set(excluded)
    assert not {d["part"] for d in report["discrepancies"]} & set(excluded)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 5])
def test_other_seeds_match_the_geometry_and_put_nothing_into_anything(tmp_path, seed):
    report = check_variant(SAMPLE, make_asbuilt(SAMPLE, tmp_path / "out", seed=seed)[0].parent)
    built = _instances(load_scene(tmp_path / "out" / "scene.toml"))
    planned = _instances(load_scene(SAMPLE))
    floor = built.pop("floor")[2]
    for d in report["discrepancies"]:
        if d["kind"] not in ("moved", "added"):
            continue
        box = built[d["id"]][2]
        assert np.all(box[0, :2] >= floor[0, :2]) and np.all(box[1, :2] <= floor[1, :2])  # on the slab
        assert abs(box[0, 2]) < 1e-6  # standing on it
        hits = [i for i, (_, _, other) in built.items() if i != d["id"] and _overlap(box, other)]
        assert hits == [], f"{d['id']} {d['kind']} into {hits}"
    assert set(planned) - {d["id"] for d in report["discrepancies"]} <= set(built) | {"floor"}


def test_same_seed_same_bytes_other_seed_other_changes(tmp_path, sample_variant):
    again = tmp_path / "again"
    assert make_asbuilt(SAMPLE, again, seed=0) == [again / "scene.toml", again / "discrepancies.json"]
    for name in ("scene.toml", "discrepancies.json"):
        assert (again / name).read_bytes() == (sample_variant / name).read_bytes()
    make_asbuilt(SAMPLE, tmp_path / "other", seed=1)
    assert (tmp_path / "other" / "discrepancies.json").read_bytes() != (again / "discrepancies.json").read_bytes()


def test_variant_is_self_contained_and_keeps_the_layout(tmp_path, sample_variant):
    moved = tmp_path / "elsewhere" / "variant"
    shutil.copytree(sample_variant, moved)
    scene = load_scene(moved / "scene.toml")
    assert all(moved in p.source.parents for p in scene.parts)
    robot = moved / "robots" / "kuka_iiwa"
    assert (robot / "LICENSE.txt").is_file() and (robot / "SOURCE.md").is_file()  # the licence travels along
    assert {p.name for p in (robot / "meshes").iterdir()} == {f"link_{i}.{e}" for i in range(8) for e in ("obj", "mtl")}
    text = (moved / "scene.toml").read_text()
    assert 'mesh = "meshes/pallet.glb"' in text and 'mesh = "robots/kuka_iiwa/model.urdf"' in text


def test_small_manifest_in_mm_and_matrix_instances(tmp_path):
    planned = small_scene(tmp_path / "plan")
    for seed in range(4):
        out = tmp_path / f"v{seed}"
        make_asbuilt(planned, out, seed=seed)
        report = check_variant(planned, out)
        assert {e["part"] for e in report["excluded_parts"]} == {"ground", "north_wall"}
        assert len(report["discrepancies"]) == 5 and {d["kind"] for d in report["discrepancies"]} == set(KINDS)
    # across the seeds, the matrix instances and the mm part have been changed as well
    changed = {
        d["id"]
        for s in range(4)
        for d in json.loads((tmp_path / f"v{s}" / "discrepancies.json").read_text())["discrepancies"]
    }
    assert changed & {"rack-A", "rack-B", "machine"}


def test_companion_files_and_meshes_outside_the_scene_folder_are_copied(tmp_path):
    plan = tmp_path / "plan"
    planned = small_scene(
        plan,
        extra="""
[[parts]]
name = "shared_bin"
mesh = "../shared/bin.gltf"
units = "m"
translate = [-8.0, -8.0, 0.0]

[[parts]]
name = "lamp"
mesh = "meshes/lamp.obj"
units = "m"
translate = [8.0, -8.0, 0.0]
""",
    )
    box_file(tmp_path / "shared" / "bin.gltf", (0.5, 0.5, 0.5))  # glTF with external .bin buffers
    (plan / "meshes" / "lamp.obj").write_text("mtllib lamp.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n")
    (plan / "meshes" / "lamp.mtl").write_text("newmtl a\nKd 1 1 1\nmap_Kd textures/lamp.png\n")
    (plan / "meshes" / "textures").mkdir()
    (plan / "meshes" / "textures" / "lamp.png").write_bytes(b"\x89PNG fake")
    out = tmp_path / "out"
    make_asbuilt(planned, out, seed=3)
    # the scene's own files keep their paths; the outside one goes to external/1/ with its buffers
    assert (out / "meshes" / "textures" / "lamp.png").is_file()
    assert sorted(p.name for p in (out / "external" / "1").iterdir()) == [
        "bin.gltf",
        "gltf_buffer_0.bin",
        "gltf_buffer_1.bin",
    ]
    assert 'mesh = "external/1/bin.gltf"' in (out / "scene.toml").read_text()
    check_variant(planned, out)
    away = tmp_path / "away"
    shutil.copytree(out, away)
    shutil.rmtree(tmp_path / "shared")  # the copy must not reach back to the planned files
    shutil.rmtree(plan / "meshes")
    assert load_scene(away / "scene.toml").triangle_count == load_scene(out / "scene.toml").triangle_count


def test_absolute_mesh_paths_go_to_numbered_external_folders_with_their_package_licence(tmp_path):
    """Meshes named by absolute paths, a robot package whose one licence lies a folder above its
    URDF (as pybullet_data/LICENSE.txt does): nothing mirrors the file system from /, and the
    licence travels along, where it was relative to the URDF."""
    from mrcheck.scene import robots

    package = tmp_path / "data" / "robot_pkg"
    urdf = robots.copy_robot("kuka_iiwa", package)
    (urdf.parent / "LICENSE.txt").rename(package / "LICENSE.txt")
    (package / "README.md").write_text("about the whole package")  # not a licence: stays behind
    box_file(tmp_path / "elsewhere" / "bin.glb", (0.5, 0.5, 0.5))
    planned = small_scene(
        tmp_path / "plan",
        extra=f"""
[[parts]]
name = "arm"
mesh = "{urdf}"
units = "m"
translate = [-7.0, 7.0, 0.0]

[[parts]]
name = "bin"
mesh = "{tmp_path / "elsewhere" / "bin.glb"}"
units = "m"
translate = [-8.0, -8.0, 0.0]
""",
    )
    out = tmp_path / "out"
    make_asbuilt(planned, out, seed=1)
    text = (out / "scene.toml").read_text()
    assert 'mesh = "external/1/kuka_iiwa/robot.urdf"' in text and 'mesh = "external/2/bin.glb"' in text
    assert (out / "external" / "1" / "LICENSE.txt").is_file() and (
        out / "external" / "1" / "kuka_iiwa" / "SOURCE.md"
    ).is_file()
    assert not (out / "external" / "1" / "README.md").exists()
    assert sorted(p.name for p in out.iterdir()) == ["discrepancies.json", "external", "meshes", "scene.toml"]
    check_variant(planned, out)
    # and an earlier variant with external/ is replaced, external/ included, when its folder is reused
    (out / "external" / "stale").mkdir()
    make_asbuilt(planned, out, seed=2)
    assert not (out / "external" / "stale").exists()


def test_a_tiny_scene_gets_one_change(tmp_path):
    box_file(tmp_path / "slab.stl", (10, 10, 0.1), lift=False)
    box_file(tmp_path / "crate.stl", (1, 1, 1))
    (tmp_path / "scene.toml").write_text(
        '[[parts]]\nname = "slab"\nmesh = "slab.stl"\nunits = "m"\n\n'
        '[[parts]]\nname = "crate"\nmesh = "crate.stl"\nunits = "m"\ninstances = [{ translate = [-2.0, 0.0, 0.0] }, { translate = [2.0, 0.0, 0.0] }]\n'
    )
    for seed in range(3):
        report = check_variant(
            tmp_path / "scene.toml", make_asbuilt(tmp_path / "scene.toml", tmp_path / f"o{seed}", seed)[0].parent
        )
        assert len(report["discrepancies"]) == 1


def test_refuses_the_planned_folder_and_folders_of_other_files(tmp_path):
    planned = small_scene(tmp_path / "plan")
    before = sorted(p.name for p in (tmp_path / "plan").iterdir())
    for outdir in (tmp_path / "plan", tmp_path / "plan" / ".", tmp_path):
        with pytest.raises(MrcheckError, match="planned scene"):
            make_asbuilt(planned, outdir, seed=0)
    assert sorted(p.name for p in (tmp_path / "plan").iterdir()) == before
    other = tmp_path / "notes"
    other.mkdir()
    (other / "keep.txt").write_text("mine")
    with pytest.raises(MrcheckError, match="not an as-built variant"):
        make_asbuilt(planned, other, seed=0)
    assert (other / "keep.txt").read_text() == "mine"
    # an earlier variant's files are replaced, an empty folder filled; the planner's own files
    # beside the variant stay
    variant = tmp_path / "variant"
    variant.mkdir()
    make_asbuilt(planned, variant, seed=0)
    (variant / "notes.txt").write_text("mine")
    (variant / "photos").mkdir()
    (variant / "photos" / "a.jpg").write_bytes(b"jpeg")
    (variant / "meshes" / "stale.glb").write_text("from before")  # inside what the variant writes
    make_asbuilt(planned, variant, seed=1)
    assert json.loads((variant / "discrepancies.json").read_text())["seed"] == 1
    assert (variant / "notes.txt").read_text() == "mine" and (variant / "photos" / "a.jpg").read_bytes() == b"jpeg"
    assert not (variant / "meshes" / "stale.glb").exists()
    assert sorted(p.name for p in variant.iterdir()) == [
        "discrepancies.json",
        "meshes",
        "notes.txt",
        "photos",
        "scene.toml",
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes", "plan", "variant"]  # no temp folders left
    fresh = tmp_path / "fresh"
    make_asbuilt(planned, fresh, seed=1)
    for name in ("scene.toml", "discrepancies.json"):
        assert (variant / name).read_bytes() == (fresh / name).read_bytes()
    shutil.rmtree(fresh)


def test_output_given_relative_to_a_folder_inside_it(tmp_path, monkeypatch, capsys):
    """`-o .` and `-o ../variant` from inside the variant: the same folder, written in place."""
    planned = small_scene(tmp_path / "plan")
    variant = tmp_path / "variant"
    make_asbuilt(planned, variant, seed=0)
    (variant / "notes.txt").write_text("mine")
    monkeypatch.chdir(variant)
    for seed, out in ((1, "."), (2, "../variant")):
        assert main(["scene", "asbuilt", str(planned), "--seed", str(seed), "-o", out]) == 0
        assert json.loads((variant / "discrepancies.json").read_text())["seed"] == seed
        assert Path.cwd() == variant and (variant / "notes.txt").read_text() == "mine"
    capsys.readouterr()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan", "variant"]
    assert not [p for p in variant.iterdir() if p.name.startswith(".")]


def test_a_failure_while_writing_leaves_no_output_and_keeps_the_earlier_variant(tmp_path, monkeypatch):
    planned = small_scene(tmp_path / "plan")
    copies, real_copy = [], shutil.copyfile

    def failing_copy(source, target):
        copies.append(source)
        if len(copies) == 2:
            raise OSError(28, "No space left on device")
        return real_copy(source, target)

    monkeypatch.setattr(asbuilt.shutil, "copyfile", failing_copy)
    with pytest.raises(MrcheckError, match="No space left"):
        make_asbuilt(planned, tmp_path / "new" / "deep" / "out", seed=0)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan"]  # no outdir, no temp dir, no parents made for it
    monkeypatch.undo()
    make_asbuilt(planned, tmp_path / "out", seed=0)
    earlier = (tmp_path / "out" / "discrepancies.json").read_bytes()
    copies.clear()
    monkeypatch.setattr(asbuilt.shutil, "copyfile", failing_copy)
    with pytest.raises(MrcheckError):
        make_asbuilt(planned, tmp_path / "out", seed=1)
    assert (tmp_path / "out" / "discrepancies.json").read_bytes() == earlier
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "plan"]


def test_cli_writes_the_variant_and_prints_its_two_files(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["scene", "asbuilt", str(SAMPLE), "--seed", "4", "-o", str(out)]) == 0
    printed = capsys.readouterr().out.split()
    assert printed == [str(out / "scene.toml"), str(out / "discrepancies.json")]
    check_variant(SAMPLE, out)


@pytest.mark.parametrize("case", ["missing scene", "mesh file", "planned folder", "unwritable folder", "negative seed"])
def test_cli_bad_input_is_one_error_line_and_no_output(tmp_path, capsys, case):
    box_file(tmp_path / "crate.stl", (1, 1, 1))
    scene, out = {
        "missing scene": (tmp_path / "nope.toml", tmp_path / "out"),
        "mesh file": (tmp_path / "crate.stl", tmp_path / "out"),
        "planned folder": (SAMPLE, SAMPLE.parent),
        "unwritable folder": (SAMPLE, Path("/proc/variant")),
        "negative seed": (SAMPLE, tmp_path / "out"),
    }[case]
    before = sorted(os.listdir(tmp_path))
    # a negative seed would silently make the same variant as its positive twin (random.Random)
    seed = ["--seed", "-1"] if case == "negative seed" else []
    assert main(["scene", "asbuilt", str(scene), *seed, "-o", str(out)]) == 1
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert captured.out == "" and len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in captured.err
    assert sorted(os.listdir(tmp_path)) == before


def test_unnamed_parts_keep_their_ids_when_a_part_goes(tmp_path):
    # unnamed parts are named by position (part1, part2 ...): the variant must name them explicitly
    box_file(tmp_path / "slab.stl", (12, 12, 0.1), lift=False)
    box_file(tmp_path / "crate.stl", (1, 1, 1))
    crates = "".join(
        f'\n[[parts]]\nmesh = "crate.stl"\nunits = "m"\ntranslate = [{x}.0, 0.0, 0.0]\n' for x in (-4, 0, 4)
    )
    (tmp_path / "scene.toml").write_text('[[parts]]\nmesh = "slab.stl"\nunits = "m"\n' + crates)
    kinds = set()
    for seed in range(8):
        report = check_variant(
            tmp_path / "scene.toml", make_asbuilt(tmp_path / "scene.toml", tmp_path / f"o{seed}", seed)[0].parent
        )
        kinds |= {d["kind"] for d in report["discrepancies"]}
    assert "missing" in kinds


def test_what_carries_or_holds_something_stays_put(tmp_path):
    box_file(tmp_path / "slab.glb", (30, 30, 0.2), lift=False)
    box_file(tmp_path / "post.stl", (0.1, 0.1, 2.0))
    box_file(tmp_path / "panel.stl", (1.96, 0.04, 1.5))
    box_file(tmp_path / "crate.stl", (1.0, 1.0, 1.0))
    loose = ", ".join(f"{{ translate = [{x}.0, -6.0, 0.0] }}" for x in (-6, -3, 0, 3, 6))
    (tmp_path / "scene.toml").write_text(f"""
[[parts]]
name = "slab"
mesh = "slab.glb"
units = "m"
translate = [0.0, 0.0, -0.2]

[[parts]]
name = "post"
mesh = "post.stl"
units = "m"
instances = [{{ translate = [-1.0, 0.0, 0.0] }}, {{ translate = [1.0, 0.0, 0.0] }}]

[[parts]]
name = "panel"
mesh = "panel.stl"
units = "m"
translate = [0.0, 0.0, 0.2]

[[parts]]
name = "crate"
mesh = "crate.stl"
units = "m"
instances = [{{ id = "bottom", translate = [5.0, 5.0, 0.0] }}, {{ id = "top", translate = [5.0, 5.0, 1.0], scale = 0.8 }}, {loose}]
""")
    seen = {}
    for seed in range(12):
        report = check_variant(
            tmp_path / "scene.toml", make_asbuilt(tmp_path / "scene.toml", tmp_path / f"o{seed}", seed)[0].parent
        )
        for d in report["discrepancies"]:
            seen.setdefault(d["id"] if d["kind"] != "added" else d["detail"]["template"], set()).add(d["kind"])
    assert not {"post#0", "post#1", "bottom"} & set(seen)  # they carry or hold something
    assert seen.get("panel", {"missing"}) == {"missing"}  # held by its posts: only removed
    assert seen.get("top", set()) <= {"rotated", "missing", "replaced"}  # on the crate below: never moved
    assert "top" in seen and "panel" in seen  # both had their turn: the rules were exercised


def test_shows_progress_for_loading_choosing_and_copying(tmp_path, monkeypatch):
    """Bars (on a terminal: disable=None) for the scene's loading and the variant's own work,
    which takes seconds on a hall; none without a progress callback."""
    import tqdm

    shown = []

    class Recording(tqdm.tqdm):
        def __init__(self, *args, **kwargs):
            if kwargs.get("disable") is None:
                shown.append(kwargs.get("desc"))
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(tqdm, "tqdm", Recording)
    planned = small_scene(tmp_path / "plan")
    from mrcheck.cli.messages import progress_bar
    from mrcheck.core.progress import no_progress

    make_asbuilt(planned, tmp_path / "v", seed=0, progress=progress_bar)  # as `mrcheck scene asbuilt` does
    assert shown == ["loading scene", "choosing changes", "copying meshes"]
    shown.clear()
    make_asbuilt(planned, tmp_path / "w", seed=0, progress=no_progress)
    assert shown == []
