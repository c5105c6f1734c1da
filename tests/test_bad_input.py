"""Bad input to ``mrcheck render``: one line ``error: <file>: <problem>`` on stderr, exit 1, no output.

Every case runs the real command line in-process (``mrcheck.cli.main``) inside a fresh folder
and checks the whole contract: non-zero exit, exactly one stderr line starting with ``error:``
that names the offending file (or option) and the problem, no traceback, nothing on stdout, and
no output file -- neither the image, nor the AO file(s), nor a leftover ``.part`` temp file.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from mrcheck.cli import main
from mrcheck.core.camera import Camera
from mrcheck.core.errors import MrcheckError

W, H = 64, 48
SIZE = ["--width", str(W), "--height", str(H)]
BOX = ["box.stl", "--camera", "cam.json", *SIZE]  # a good scene and camera; cases vary one thing
OUT, OUT_AO = "out/render.png", "out/ao.npy"
DIR = object()  # as a file's content: make a folder of that name


def camera_dict(**changes) -> dict:
    """The good camera (outside the unit box, looking at it) with keys replaced; None drops a key."""
    data = Camera.from_look_at((3, 2, 1.5), (0, 0, 0), (0, 0, 1), 60, W, H).to_dict()
    data.update(changes)
    return {k: v for k, v in data.items() if v is not None}


def manifest(part: str = "", top: str = "", view: str = "") -> str:
    """A manifest of the unit box; ``part`` adds lines to its [[parts]] table."""
    text = f'format = 1\n{top}\n[[parts]]\nname = "box"\nmesh = "box.stl"\nunits = "m"\n{part}\n'
    return text + (f'[[viewpoints]]\nname = "v"\n{view}\n' if view else "")


def obj(vertices: str, faces: str) -> str:
    return "".join(f"v {v}\n" for v in vertices.split(",")) + "".join(f"f {f}\n" for f in faces.split(",") if f)


NAN_PLY = """ply
format ascii 1.0
element vertex 3
property float x
property float y
property float z
element face 1
property list uchar int vertex_indices
end_header
0 0 0
1 nan 0
0 1 0
3 0 1 2
"""

VIEW = "eye = [3, 2, 1.5]\ntarget = [0, 0, 0]\nwidth = 64\nheight = 48"


def case(id, files, args, problem, names="", marks=()):
    """One bad input: files to write (name -> str, bytes, dict/list as JSON, DIR or a callable(path)),
    the command line after ``render`` (a str: that scene with the good camera), a fragment of the
    problem and the file (or option) the message must name."""
    args = [args, "--camera", "cam.json"] if isinstance(args, str) else args
    return pytest.param(files, args, problem, names, id=id, marks=marks)


def mesh_case(id, name, content, problem, marks=()):
    return case(id, {name: content}, name, problem, name, marks)


def toml_case(id, text, problem, args="scene.toml", files=None):
    return case(id, {"scene.toml": text, **(files or {})}, args, problem, "scene.toml")


def view_case(id, view, problem):
    return toml_case(id, manifest(view=view), problem, ["scene.toml", "--view", "v"])


def camera_case(id, data, problem):
    return case(id, {"bad.json": data}, ["box.stl", "--camera", "bad.json"], problem, "bad.json")


def option_case(id, args, problem, names=""):
    return case(id, {}, [*BOX, *args], problem, names)


CASES = [
    # -- mesh files ---------------------------------------------------------------------------
    case("mesh-missing", {}, "gone.stl", "not found", "gone.stl"),
    case(
        "mesh-is-folder",
        {"scene.toml": manifest().replace("box.stl", "dir.stl"), "dir.stl": DIR},
        "scene.toml",
        "is a folder",
        "dir.stl",
    ),
    mesh_case(
        "mesh-unreadable",
        "locked.stl",
        lambda p: (p.write_text("solid x\n"), p.chmod(0)),
        "cannot read mesh",
        marks=pytest.mark.skipif(os.geteuid() == 0, reason="root reads any file"),
    ),
    mesh_case("mesh-empty-file", "empty.stl", b"", "file is empty"),
    mesh_case("mesh-empty-glb", "empty.glb", b"", "file is empty"),
    mesh_case("mesh-no-faces", "points.obj", obj("0 0 0,1 0 0,0 1 0", ""), "no triangles"),
    mesh_case("mesh-corrupt-glb", "bad.glb", np.random.default_rng(0).bytes(600), "cannot read mesh"),
    mesh_case(
        "mesh-ply-cut-in-vertices",
        "cut.ply",
        NAN_PLY.split("1 nan 0")[0] + "1 0\n",
        "cannot read mesh: corrupt, truncated or not a mesh",
    ),
    mesh_case("mesh-unknown-suffix", "model.xyz", "1 2 3\n", "unsupported mesh format"),
    mesh_case("mesh-nan-obj", "nan.obj", obj("0 0 0,1 0 0,0 nan 0,0 0 1", "1 2 3,1 2 4"), "NaN"),
    mesh_case("mesh-inf-obj", "inf.obj", obj("0 0 0,1 0 0,0 inf 0", "1 2 3"), "infinite"),
    mesh_case("mesh-nan-ply", "nan.ply", NAN_PLY, "NaN"),
    mesh_case("mesh-all-degenerate", "flat.obj", obj("0 0 0,1 0 0,2 0 0", "1 2 3,1 1 2"), "degenerate"),
    mesh_case("mesh-one-point", "dot.obj", obj("1 1 1,1 1 1,1 1 1", "1 2 3"), "degenerate"),
    mesh_case("mesh-bad-index", "idx.obj", obj("0 0 0,1 0 0,0 1 0", "1 2 9"), "index"),
    option_case("mesh-units-unknown", ["--units", "furlong"], "furlong", "--units"),
    # -- scene ------------------------------------------------------------------------------------
    case("scene-folder-no-manifest", {"hall": DIR}, "hall", "no scene manifest", "hall"),
    case("scene-camera-inside", {}, ["bigbox.stl", "--camera", "inside.json"], "inside geometry", "bigbox.stl"),
    toml_case(
        "scene-units-with-manifest",
        manifest(),
        "--units applies",
        ["scene.toml", "--camera", "cam.json", "--units", "mm"],
    ),
    # -- manifest -----------------------------------------------------------------------------------
    toml_case("toml-malformed", "[[parts]\nname = ", "malformed manifest"),
    toml_case("toml-not-utf8", b"\xff\xfe\x00bad", "cannot read manifest"),
    toml_case("toml-no-parts", "format = 1\n", "scene is empty"),
    toml_case("toml-parts-not-array", '[parts]\nmesh = "box.stl"\n', "array of tables"),
    toml_case("toml-format-2", manifest().replace("format = 1", "format = 2"), "format 2"),
    toml_case("toml-unit-unknown", manifest().replace('"m"', '"furlong"'), "unknown units 'furlong'"),
    toml_case("toml-unit-not-a-string", manifest().replace('"m"', '["m"]'), "unknown units"),
    case(
        "toml-mesh-missing",
        {"scene.toml": manifest().replace("box.stl", "meshes/gone.glb")},
        "scene.toml",
        "not found (part 'box' of ",
        "gone.glb",
    ),  # the manifest entry that asked for it, too
    case(
        "toml-mesh-nan",
        {"scene.toml": manifest().replace("box.stl", "nan.ply"), "nan.ply": NAN_PLY},
        "scene.toml",
        "NaN",
        "nan.ply",
    ),
    toml_case("toml-mesh-entry-missing", manifest().replace('mesh = "box.stl"', ""), "needs a mesh"),
    toml_case("toml-duplicate-names", manifest() + manifest().replace("format = 1", ""), "two parts are named"),
    toml_case("toml-unknown-key", manifest("colour = [1, 0, 0]"), "unknown key(s) colour"),
    toml_case(
        "toml-unknown-instance-key", manifest("instances = [{ translte = [0, 1, 0] }]"), "unknown key(s) translte"
    ),
    toml_case("toml-instances-empty", manifest("instances = []"), "instances is empty"),
    toml_case(
        "toml-instance-id-twice",
        manifest('instances = [{ id = "A" }, { id = "A" }]'),
        "instance id 'A' is used twice in part 'box'",
    ),
    # ids name one object in the whole scene: across parts, and generated ids (NAME#i) included
    toml_case(
        "toml-instance-id-two-parts",
        manifest('instances = [{}, { id = "X" }]')
        + manifest('instances = [{ id = "X" }]').replace("format = 1", "").replace('"box"', '"post"'),
        "instance id 'X' is used by parts 'box' and 'post'",
    ),
    toml_case(
        "toml-instance-id-generated",
        manifest("instances = [{}, {}]")
        + manifest('instances = [{ id = "box#1" }]').replace("format = 1", "").replace('"box"', '"post"'),
        "instance id 'box#1' is used by parts 'box' and 'post'",
    ),
    toml_case(
        "toml-instance-id-part-name",
        manifest()
        + manifest('instances = [{ id = "box" }]').replace("format = 1", "").replace('name = "box"', 'name = "post"'),
        "instance id 'box' is used by parts 'box' and 'post'",
    ),
    toml_case("toml-scale-negative", manifest("scale = -1.0"), "scale must be positive"),
    toml_case("toml-scale-text", manifest('scale = "big"'), "must be numbers"),
    toml_case("toml-instance-scale-zero", manifest("instances = [{ scale = 0 }]"), "scale must be positive"),
    toml_case("toml-translate-short", manifest("translate = [1, 2]"), "translate must be three"),
    toml_case("toml-translate-nan", manifest("translate = [1, nan, 0]"), "finite"),
    toml_case("toml-rotate-text", manifest('rotate_deg = "xyz"'), "rotate_deg"),
    toml_case("toml-matrix-3x3", manifest("matrix = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]"), "4x4"),
    toml_case(
        "toml-matrix-singular",
        manifest("matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]]"),
        "singular",
    ),
    toml_case(
        "toml-matrix-projective",
        manifest("matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]"),
        "bottom row",
    ),
    toml_case(
        "toml-matrix-and-translate",
        manifest("translate = [0, 0, 0]\nmatrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"),
        "not both",
    ),
    toml_case("toml-color-text", manifest('color = "red"'), "color"),
    toml_case("toml-color-range", manifest("color = [2, 0, 0]"), "color"),
    toml_case("toml-viewpoints-not-array", manifest(top='viewpoints = "v"'), "viewpoints"),
    toml_case("toml-view-unknown", manifest(view=VIEW), "no viewpoint named 'nope'", ["scene.toml", "--view", "nope"]),
    toml_case(
        "toml-view-duplicate", manifest(view=VIEW) + f'[[viewpoints]]\nname = "v"\n{VIEW}\n', "two viewpoints are named"
    ),
    view_case("toml-view-no-eye", "target = [0, 0, 0]", "eye"),
    view_case("toml-view-width-zero", VIEW.replace("64", "0"), "positive"),
    view_case("toml-view-width-negative", VIEW.replace("64", "-5"), "positive"),
    view_case("toml-view-width-text", VIEW.replace("64", '"wide"'), "width"),
    view_case("toml-view-eye-short", VIEW.replace("[3, 2, 1.5]", "[3, 2]"), "eye must be three"),
    view_case("toml-view-eye-nan", VIEW.replace("[3, 2, 1.5]", "[3, nan, 1.5]"), "eye must be three finite"),
    view_case("toml-view-fov-zero", VIEW + "\nfov_y_deg = 0", "fov_y_deg"),
    view_case("toml-view-fov-text", VIEW + '\nfov_y_deg = "wide"', "fov_y_deg"),
    # -- camera JSON -------------------------------------------------------------------------------
    case("cam-missing", {}, ["box.stl", "--camera", "gone.json"], "not found", "gone.json"),
    camera_case("cam-malformed-json", '{"width": 64,', "malformed camera JSON"),
    camera_case("cam-not-object", [1, 2], "must be an object"),
    camera_case("cam-no-K", camera_dict(K=None), "missing K"),
    camera_case("cam-K-2x2", camera_dict(K=[[50, 0], [0, 50]]), "K must have shape"),
    camera_case("cam-K-ragged", camera_dict(K=[[50, 0, 32], [0, 50]]), "camera K"),
    camera_case("cam-K-text", camera_dict(K="identity"), "camera K"),
    camera_case("cam-K-zero-focal", camera_dict(K=[[0, 0, 32], [0, 0, 24], [0, 0, 1]]), "focal"),
    camera_case("cam-width-negative", camera_dict(width=-5), "positive"),
    camera_case("cam-width-zero", camera_dict(width=0), "positive"),
    camera_case("cam-width-fraction", camera_dict(width=64.5), "whole"),
    camera_case("cam-width-text", camera_dict(width="64"), "width"),
    camera_case("cam-width-infinite", camera_dict(width=float("inf")), "width"),
    camera_case("cam-R-not-rotation", camera_dict(R=(2 * np.eye(3)).tolist()), "not a rotation"),
    camera_case("cam-R-mirror", camera_dict(R=np.diag([1.0, 1.0, -1.0]).tolist()), "not a rotation"),
    camera_case("cam-t-nan", camera_dict(t=[0.0, float("nan"), 5.0]), "NaN"),
    camera_case("cam-t-short", camera_dict(t=[0.0, 5.0]), "shape"),
    camera_case("cam-dist-nan", camera_dict(dist=[0.1, float("nan"), 0, 0, 0]), "dist"),
    option_case("cam-and-view", ["--view", "v"], "exactly one"),
    case("cam-nor-view", {}, ["box.stl"], "exactly one"),
    # -- options --------------------------------------------------------------------------------
    option_case("width-zero", ["--width", "0"], "positive", "--width"),
    option_case("width-negative", ["--width", "-5"], "positive", "--width"),
    option_case("width-text", ["--width", "wide"], "integer", "--width"),
    option_case("height-zero", ["--height", "0"], "positive", "--height"),
    option_case("samples-zero", ["--samples", "0"], "positive", "--samples"),
    option_case("samples-too-many", ["--samples", "100000"], "samples"),
    option_case("blur-size-even", ["--blur-size", "4"], "odd", "--blur-size"),
    option_case("blur-size-one-phong", ["--mode", "phong", "--blur-size", "1"], "odd", "--blur-size"),
    option_case("radius-px-negative", ["--radius-px", "-1"], "positive", "--radius-px"),
    option_case("radius-px-nan", ["--radius-px", "nan"], "nan is not a finite number", "--radius-px"),
    option_case("radius-fraction-above-one", ["--radius-fraction", "2"], "radius fraction"),
    option_case("falloff-negative", ["--falloff", "-1"], "falloff"),
    option_case("intensity-negative", ["--intensity", "-1"], "intensity"),
    option_case("intensity-infinite", ["--intensity", "inf"], "finite"),
    option_case("seed-negative", ["--seed", "-1"], "-1", "--seed"),
    option_case("radius-px-and-fraction", ["--radius-px", "5", "--radius-fraction", "0.1"], "not both"),
    option_case("world-radius-min-above-max", ["--min-world-radius", "5", "--max-world-radius", "1"], "exceeds"),
    option_case("mode-unknown", ["--mode", "raytraced"], "raytraced", "--mode"),
    option_case("size-too-large", ["--width", "100000", "--height", "75000"], "exceeds"),  # the camera's 4:3
    # -- outputs ---------------------------------------------------------------------------------
    option_case("output-suffix", ["-o", "out/render.gif"], "must end in", "render.gif"),
    option_case("output-no-suffix", ["-o", "out/render"], "must end in", "out/render"),
    case("output-is-folder", {OUT: DIR}, BOX, "is a directory", OUT),
    option_case("output-parent-is-file", ["-o", "box.stl/render.png"], "is a file, not a folder", "box.stl"),
    # /proc takes no new files, even from root (whom permission bits never stop)
    option_case(
        "output-folder-unwritable", ["-o", "/proc/render.png"], "folder /proc is not writable", "/proc/render.png"
    ),
    option_case(
        "output-ao-folder-unwritable", ["--output-ao", "/proc/ao.npy"], "cannot write AO output", "/proc/ao.npy"
    ),
    option_case("output-ao-suffix", ["--output-ao", "out/ao.txt"], "AO output must end in", "ao.txt"),
    option_case("output-ao-with-phong", ["--mode", "phong", "--output-ao", OUT_AO], "not phong"),
    option_case("output-ao-same-as-image", ["-o", "out/x.png", "--output-ao", "out/x.png"], "same file", "x.png"),
    option_case(
        "output-ao-all-clashes",
        ["--mode", "all", "-o", "out/ao_vector.png", "--output-ao", "out/ao.png"],
        "same file",
        "ao_vector.png",
    ),
]


@pytest.fixture
def folder(tmp_path, monkeypatch):
    """A fresh working folder with a unit box, a camera looking at it, and a 20 m box and a
    camera at its centre (which sees only the inside walls)."""
    monkeypatch.chdir(tmp_path)
    trimesh.creation.box().export("box.stl")
    trimesh.creation.box(extents=(20, 20, 20)).export("bigbox.stl")
    Path("cam.json").write_text(json.dumps(camera_dict()))
    inside = Camera.from_look_at((0, 0, 0), (1, 0.3, 0.2), (0, 0, 1), 60, W, H)
    Path("inside.json").write_text(json.dumps(inside.to_dict()))
    return tmp_path


def write_files(files: dict) -> None:
    for name, content in files.items():
        path = Path(name)
        path.parent.mkdir(parents=True, exist_ok=True)
        if content is DIR:
            path.mkdir()
        elif callable(content):
            content(path)
        elif isinstance(content, bytes):
            path.write_bytes(content)
        elif isinstance(content, str):
            path.write_text(content)
        else:
            path.write_text(json.dumps(content))


def with_outputs(args: list) -> list:
    """``render`` + args, with the image and (except for phong) AO outputs unless the case gives its own."""
    image = [] if "-o" in args else ["-o", OUT]
    ao = [] if "--output-ao" in args or "phong" in args else ["--output-ao", OUT_AO]
    return ["render", *args, *image, *ao]


def outputs_left(before: set) -> list:
    """Files that appeared under out/ (or anywhere new in the folder): outputs or temp files."""
    return sorted(str(p) for p in Path(".").rglob("*") if p.is_file() and str(p) not in before)


def check_error(rc: int, err: str, out: str, problem: str, names: str) -> None:
    assert rc == 1, f"exit {rc}, stderr {err!r}"
    assert out == "", out
    assert "Traceback" not in err
    assert err.endswith("\n") and err.count("\n") == 1, f"not one line: {err!r}"
    assert err.startswith("error: "), err
    assert problem in err, f"{problem!r} not in {err!r}"
    assert names in err, f"{names!r} not named in {err!r}"


@pytest.mark.parametrize("files, args, problem, names", CASES)
def test_bad_input(folder, capsys, files, args, problem, names):
    write_files(files)
    before = {str(p) for p in Path(".").rglob("*") if p.is_file()}
    rc = main(with_outputs(args))
    captured = capsys.readouterr()
    check_error(rc, captured.err, captured.out, problem, names)
    assert outputs_left(before) == []


@pytest.mark.parametrize(
    "files, args, warning",
    [
        pytest.param({}, [*BOX, "--mode", "all"], None, id="good-box"),
        pytest.param(
            {"some.obj": obj("0 0 0,1 0 0,2 0 0,0 1 0", "1 2 3,1 2 4")},
            ["some.obj", "--camera", "cam.json", *SIZE],
            "dropped 1 degenerate triangles of 2",
            id="some-degenerate",
        ),
    ],
)
def test_good_input_renders(folder, capsys, files, args, warning):
    """The harness is not vacuous: the good scene renders, and a mesh with only some degenerate
    triangles renders too, with a one-line warning."""
    write_files(files)
    rc = main(with_outputs(args))
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    assert captured.err == (f"warning: some.obj: {warning}\n" if warning else "")
    written = sorted(os.listdir("out"))
    assert written == (["ao_ssao.npy", "ao_vector.npy", "render.png"] if "all" in args else ["ao.npy", "render.png"])


def test_failed_image_write_removes_ao_files(folder, capsys, monkeypatch):
    """All outputs or none: when the image cannot be written after the AO files were, the AO files go."""
    import mrcheck.render.views

    def full_disk(path, image):
        raise MrcheckError("cannot write output (No space left on device)", path)

    monkeypatch.setattr(mrcheck.render.views, "write_image", full_disk)
    rc = main(["render", *BOX, "--mode", "all", "-o", OUT, "--output-ao", OUT_AO])
    captured = capsys.readouterr()
    check_error(rc, captured.err, captured.out, "No space left", "render.png")
    assert os.listdir("out") == []


def test_usage_error_exits_2(folder, capsys):
    """A malformed command line (no -o) is click's usage error: exit 2, not a bad-input error."""
    assert main(["render", *BOX]) == 2
    assert "Missing option '-o'" in capsys.readouterr().err


@pytest.mark.slow
def test_real_process(folder):
    """The contract holds for a real process: exit status 1, one stderr line (no progress bar
    either, stderr being a pipe), no output file."""
    write_files(
        {"scene.toml": manifest().replace("box.stl", "nan.obj"), "nan.obj": obj("0 0 0,1 0 0,0 nan 0", "1 2 3")}
    )
    result = subprocess.run(
        [sys.executable, "-m", "mrcheck.cli", *with_outputs(["scene.toml", "--camera", "cam.json"])],
        capture_output=True,
        text=True,
        timeout=120,
    )
    check_error(result.returncode, result.stderr, result.stdout, "NaN", "nan.obj")
    assert not Path("out").exists()
