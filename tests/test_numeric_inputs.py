"""NaN and infinity in every numeric input of every command: option values, camera files (JSON
and OpenCV YAML), correspondences, marker maps, job files, scene manifests, scans, suggestions.

Python's json and TOML read ``NaN``, ``Infinity``, ``nan`` and ``inf`` as numbers, and click's
float type takes "nan" and "inf": each must be refused, not compared (``nan <= 1`` is False, so
a check written ``if x > 1: fail`` lets it through) or used (an infinite world radius rendered).
Every case runs the real command line in-process and checks: exit 1, one ``error:`` line (after
a review's ``warning:`` for the shot it skipped) naming the file or option, the key and the real
problem, no traceback, and nothing written: every file of the folder as before.

Decimal commas in text scans (``1,25 2,50 0,10``, once read as the six numbers 1, 25, 2, 50, 0,
10) are numeric input too: refused with the file and the line.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mrcheck.cli import main
from mrcheck.core.resources import sample_scene_path

from .project_files import (  # noqa: F401
    camera,
    correspondences,
    intrinsics,
    job,
    manifest,
    marker_map,
    project,
    run_refused,
    shot,
    snapshot,
    write_files,
)

NAN, INF = float("nan"), float("inf")
BAD = (NAN, INF, -INF)


def case(id, args, fragments, files=None):
    """``args`` after ``mrcheck``; ``fragments``: what the error must say (the file or option,
    the key, the problem); ``files``: the case's own files besides the project's."""
    return pytest.param(list(args), tuple(fragments), files or {}, id=id)


def text(value: float) -> str:
    """A float as the command line and TOML write it: nan, inf, -inf."""
    return repr(value)


# -- command-line options -----------------------------------------------------------------------------
RENDER = ["render", "scene.toml", "--camera", "cam.json", "-o", "out/r.png"]
OPTIONS = {  # every float option of every command, on a command line that works without it
    "render": (
        RENDER,
        [
            "--radius-px",
            "--radius-fraction",
            "--min-world-radius",
            "--max-world-radius",
            "--falloff",
            "--intensity",
            "--lod-px",
        ],
    ),
    "render-ssao": ([*RENDER, "--mode", "ssao"], ["--radius"]),
    "render-vbao": ([*RENDER, "--mode", "vbao"], ["--thickness"]),
    "overlay": (["overlay", "shot.json", "--scene", "scene.toml", "-o", "out/o.png"], ["--alpha", "--intensity"]),
    "register": (
        [
            "register",
            "scene.toml",
            "--photo",
            "photo.png",
            "--intrinsics",
            "intr.json",
            "--points",
            "corr.json",
            "-o",
            "out/s.json",
        ],
        ["--max-error", "--click-sigma"],
    ),
    "calibrate": (
        ["calibrate", "photo.png", "--board", "chessboard:9x6:0.025", "-o", "out/c.json"],
        ["--max-view-error"],
    ),
    "reference": (
        ["reference", "scene.toml", "--camera", "cam.json", "--rays", "4", "-o", "out/r.npy"],
        ["--radius-px", "--falloff"],
    ),
    "reference-world": (
        ["reference", "scene.toml", "--camera", "cam.json", "--rays", "4", "--radius-mode", "world", "-o", "out/r.npy"],
        ["--radius"],
    ),
    "discrepancies": (["discrepancies", "shot.json", "--scene", "scene.toml", "-o", "out/d"], ["--tolerance-px"]),
    "deviation": (
        ["deviation", "scan.xyz", "--scene", "scene.toml", "--per-element", "-o", "out/v"],
        ["--tolerance-mm", "--search-mm"],
    ),
    "track": (
        [
            "track",
            "walk.mp4",
            "--scene",
            "scene.toml",
            "--intrinsics",
            "intr.json",
            "--initial",
            "cam.json",
            "-o",
            "out/t.mp4",
        ],
        ["--alpha"],
    ),
}
OPTION_CASES = [
    case(f"{name}{option}={text(v)}", [*args, option, text(v)], [option, f"{text(v)} is not a finite number"])
    for name, (args, options) in OPTIONS.items()
    for option in options
    for v in BAD
]
OPTION_CASES += [
    case(
        f"scene-generate--size-m-{i}={text(v)}",
        [
            "scene",
            "generate",
            "--preset",
            "cell",
            "--size-m",
            *[text(v) if j == i else s for j, s in enumerate(("20", "15", "6"))],
            "-o",
            "out/g",
        ],
        ["--size-m", f"{text(v)} is not a finite number"],
    )
    for i in range(3)
    for v in (NAN, INF)
]
WALL_IFC = Path(__file__).parent / "data" / "cad" / "ifc" / "wall-standard-case.ifc"
OPTION_CASES += [
    case(
        f"scene-import{option}={text(v)}",
        ["scene", "import", "wall.ifc", option, text(v), "-o", "out/i"],
        [option, f"{text(v)} is not a finite number"],
        {"wall.ifc": WALL_IFC.read_text()},
    )
    for option in ("--tolerance-px", "--at-distance")
    for v in BAD
]
BOARD_CASES = [
    case(
        f"calibrate-board-{spec}",
        ["calibrate", "photo.png", "--board", spec, "-o", "out/c.json"],
        ["board SPEC", spec, "got"],
    )
    for spec in (
        "chessboard:9x6:nan",
        "chessboard:9x6:inf",
        "charuco:5x7:nan:0.03:DICT_6X6_250",
        "charuco:5x7:0.04:inf:DICT_6X6_250",
    )
]

# -- camera files: every command that reads one --------------------------------------------------------
CAMERA_KEYS = {  # key: (how the bad value goes in, what the message says)
    "K": (lambda d, v: d.update(K=[[v, 0, 31.5], [0, 41.6, 23.5], [0, 0, 1]]), "camera K contains NaN or infinite"),
    "dist": (lambda d, v: d.update(dist=[0.1, v, 0, 0, 0]), "camera dist contains NaN or infinite"),
    "R": (lambda d, v: d.update(R=[[1, 0, 0], [0, v, 0], [0, 0, 1]]), "camera R contains NaN or infinite"),
    "t": (lambda d, v: d.update(t=[0, v, 5]), "camera t contains NaN or infinite"),
    "width": (lambda d, v: d.update(width=v), "camera width must be a whole number"),
}
CAMERA_USERS = {  # command line reading bad.json, and the camera dict it needs (a pose or not)
    "render": (["render", "scene.toml", "--camera", "bad.json", "-o", "out/r.png"], camera().to_dict),
    "reference": (
        ["reference", "scene.toml", "--camera", "bad.json", "--rays", "4", "-o", "out/r.npy"],
        camera().to_dict,
    ),
    "register": (
        [
            "register",
            "scene.toml",
            "--photo",
            "photo.png",
            "--intrinsics",
            "bad.json",
            "--points",
            "corr.json",
            "-o",
            "out/s.json",
        ],
        intrinsics,
    ),
    "overlay": (["overlay", "bad.json", "--scene", "scene.toml", "-o", "out/o.png"], shot),
    "discrepancies": (["discrepancies", "bad.json", "--scene", "scene.toml", "-o", "out/d"], shot),
    "deviation": (["deviation", "scan.xyz", "--scene", "scene.toml", "--shot", "bad.json", "-o", "out/d"], shot),
    "review": (["review", "scene.toml", "--shots", "bad"], lambda: shot("../photo.png")),
    "export-intrinsics": (["export", "ijob.toml", "-o", "out/e"], intrinsics),
}


def bad_camera(user: str, key: str, value: float) -> dict:
    args, good = CAMERA_USERS[user]
    data = good()
    if key in ("R", "t") and "R" not in data:
        return None  # intrinsics have no pose
    CAMERA_KEYS[key][0](data, value)
    name = "bad/s.json" if user == "review" else "bad.json"
    files = {name: data}
    if user == "export-intrinsics":
        files["ijob.toml"] = job('[[shots]]\nphoto = "photo.png"\nintrinsics = "bad.json"\npoints = "corr.json"\n')
    return files


CAMERA_CASES = [
    case(
        f"{user}-camera-{key}={text(v)}", CAMERA_USERS[user][0], ["bad", CAMERA_KEYS[key][1]], bad_camera(user, key, v)
    )
    for user in CAMERA_USERS
    for key in CAMERA_KEYS
    for v in (NAN, INF)
    if bad_camera(user, key, v) is not None
]
YAML = """%YAML:1.0
---
image_width: 64
image_height: 48
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ {fx}, 0., 31.5, 0., 41.6, 23.5, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 5
   cols: 1
   dt: d
   data: [ 0., {k2}, 0., 0., 0. ]
"""
CAMERA_CASES += [
    case(
        f"register-yaml-{name}",
        [
            "register",
            "scene.toml",
            "--photo",
            "photo.png",
            "--intrinsics",
            "bad.yml",
            "--points",
            "corr.json",
            "-o",
            "out/s.json",
        ],
        ["bad.yml", problem],
        {"bad.yml": YAML.format(**{"fx": "41.6", "k2": "0.", **values})},
    )
    for name, values, problem in [
        ("K-nan", {"fx": ".nan"}, "camera K contains NaN or infinite"),
        ("K-inf", {"fx": ".inf"}, "camera K contains NaN or infinite"),
        ("dist-nan", {"k2": ".nan"}, "camera dist contains NaN or infinite"),
    ]
]


# -- correspondences and marker maps: register, and an export job that names them ----------------------
def bad_points(where: str, value: float) -> dict:
    data = correspondences()
    data["points"][2][where][1] = value
    return data


def bad_map(key: str, value: float) -> dict:
    if key == "corners":
        data = marker_map()
        data["markers"][0]["corners"][1][0] = value
        return data
    board = {"squares": [5, 7], "square": 0.04, "marker": 0.03, "pose": {"R": np.eye(3).tolist(), "t": [0, 0, 0]}}
    if key in ("square", "marker"):
        board[key] = value
    else:
        board["pose"][key][1] = value if key == "t" else [0, value, 0]
    return {"dictionary": "DICT_6X6_250", "charuco_boards": [board]}


MAP_PROBLEMS = {
    "corners": "marker 1 corners must be 4 x 3 finite numbers",
    "square": "square: {v} is not a finite number",
    "marker": "marker: {v} is not a finite number",
    "R": "pose R must be 3 x 3 finite numbers",
    "t": "pose t must be 3 finite numbers",
}
EXPORT_IJOB = ["export", "ijob.toml", "-o", "out/e"]
REGISTER = ["register", "scene.toml", "--photo", "photo.png", "--intrinsics", "intr.json", "-o", "out/s.json"]
POINTS_JOB = job('[[shots]]\nphoto = "photo.png"\nintrinsics = "intr.json"\npoints = "bad.json"\n')
MARKERS_JOB = job('[[shots]]\nphoto = "photo.png"\nintrinsics = "intr.json"\nmarkers = "bad.json"\n')
REGISTRATION_CASES = [
    *(
        case(
            f"{command}-points-{where}={text(v)}",
            args,
            ["bad.json", "point #2", "finite numbers"],
            {"bad.json": bad_points(where, v), "ijob.toml": POINTS_JOB},
        )
        for command, args in (("register", [*REGISTER, "--points", "bad.json"]), ("export", EXPORT_IJOB))
        for where in ("pixel", "world")
        for v in (NAN, INF)
    ),
    *(
        case(
            f"{command}-markers-{key}={text(v)}",
            args,
            ["bad.json", MAP_PROBLEMS[key].format(v=text(v))],
            {"bad.json": bad_map(key, v), "ijob.toml": MARKERS_JOB},
        )
        for command, args in (("register", [*REGISTER, "--markers", "bad.json"]), ("export", EXPORT_IJOB))
        for key in MAP_PROBLEMS
        for v in (NAN, INF)
    ),
]

# -- job files: export and review read them ---------------------------------------------------------------
JOB_KEYS = {  # key = TOML value (VALUE: the bad one) -> what the message says
    "alphas": ("[0.5, VALUE]", "alphas: VALUE is not a finite number"),
    "intensities": ("[1.0, VALUE]", "intensities: VALUE is not a finite number"),
    "overlay_intensity": ("VALUE", "overlay_intensity: VALUE is not a finite number"),
    "max_registration_error_px": ("VALUE", "max_registration_error_px: VALUE is not a finite number"),
    "samples": ("VALUE", "samples must be a whole number 1..512, got VALUE"),
}
JOB_CASES = [
    case(
        f"{command}-job-{key}={text(v)}",
        [command, "bad.toml", *args],
        ["bad.toml", problem.replace("VALUE", text(v))],
        {
            "bad.toml": job(extra=f"{key} = {value.replace('VALUE', text(v))}").replace("samples = 4\n", "")
            if key == "samples"
            else job(extra=f"{key} = {value.replace('VALUE', text(v))}")
        },
    )
    for command, args in (("export", ["-o", "out/e"]), ("review", []))
    for key, (value, problem) in JOB_KEYS.items()
    for v in BAD
]
JOB_CASES += [
    case(
        "export-job-alphas-out-of-range-first",
        ["export", "bad.toml", "-o", "out/e"],
        ["bad.toml", "alphas: 2.0 is outside 0..1"],
        {"bad.toml": job(extra="alphas = [2.0, nan]")},
    ),
    case(
        "export-job-width-nan",
        ["export", "bad.toml", "-o", "out/e"],
        ["bad.toml", "width", "got nan"],
        {"bad.toml": job().replace("width = 64", "width = nan")},
    ),
]

# -- scene manifests: every command loads them through one reader; every key in render and scene info ------
ROBOT = (sample_scene_path().parent / "robots" / "kuka_iiwa" / "model.urdf").as_posix()
MANIFEST_KEYS = {  # id: (manifest text with VALUE, what the message says)
    "scale": (manifest(part="scale = VALUE"), "part 'box': scale: VALUE is not a finite number"),
    "translate": (manifest(part="translate = [0, VALUE, 0]"), "part 'box' translate must be three finite numbers"),
    "rotate_deg": (manifest(part="rotate_deg = [VALUE, 0, 0]"), "part 'box' rotate_deg must be three finite numbers"),
    "matrix": (
        manifest(part="matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, VALUE], [0, 0, 0, 1]]"),
        "part 'box': matrix has NaN or infinite values",
    ),
    "color": (manifest(part="color = [VALUE, 0, 0]"), "part 'box': color must be three numbers in 0..1"),
    "instance-translate": (
        manifest(part="instances = [{ translate = [VALUE, 0, 0] }]"),
        "part 'box' instance 0 translate must be three finite numbers",
    ),
    "instance-scale": (
        manifest(part="instances = [{ scale = VALUE }]"),
        "part 'box' instance 0: scale: VALUE is not a",
    ),
    "instance-rotate_deg": (
        manifest(part="instances = [{ rotate_deg = [0, 0, VALUE] }]"),
        "part 'box' instance 0 rotate_deg must be three finite numbers",
    ),
    "view-eye": (
        manifest().replace("eye = [3, 2, 1.5]", "eye = [3, VALUE, 1.5]"),
        "viewpoint 'v': eye must be three finite",
    ),
    "view-target": (
        manifest().replace("target = [0, 0, 0]", "target = [0, 0, VALUE]"),
        "viewpoint 'v': target must be three finite",
    ),
    "view-up": (manifest(view="up = [0, 0, VALUE]"), "viewpoint 'v': up must be three finite"),
    "view-fov_y_deg": (manifest(view="fov_y_deg = VALUE"), "viewpoint 'v': fov_y_deg must be between 0 and 180"),
    "view-width": (manifest().replace("width = 64", "width = VALUE"), "viewpoint 'v'"),
    "robot-joint": (
        manifest(ROBOT, part="joints = { lbr_iiwa_joint_2 = VALUE }"),
        "joint 'lbr_iiwa_joint_2' must be a finite",
    ),
}
SCENE_READERS = {
    "render": ["render", "bad.toml", "--view", "v", "-o", "out/r.png"],
    "scene-info": ["scene", "info", "bad.toml"],
}
MANIFEST_CASES = [
    case(
        f"{reader}-manifest-{key}={text(v)}",
        args,
        ["bad.toml", problem.replace("VALUE", text(v))],
        {"bad.toml": content.replace("VALUE", text(v))},
    )
    for reader, args in SCENE_READERS.items()
    for key, (content, problem) in MANIFEST_KEYS.items()
    for v in (NAN, INF)
]
OTHER_SCENE_READERS = {  # the rest of the commands that load a scene: one bad key each, the same reader
    "reference": ["reference", "bad.toml", "--view", "v", "--rays", "4", "-o", "out/r.npy"],
    "overlay": ["overlay", "shot.json", "--scene", "bad.toml", "-o", "out/o.png"],
    "register": [
        "register",
        "bad.toml",
        "--photo",
        "photo.png",
        "--intrinsics",
        "intr.json",
        "--points",
        "corr.json",
        "-o",
        "out/s.json",
    ],
    "compare": ["compare", "bad.toml", "--view", "v", "--rays", "4", "-o", "out/c"],
    "deviation": ["deviation", "scan.xyz", "--scene", "bad.toml", "-o", "out/d"],
    "discrepancies": ["discrepancies", "shot.json", "--scene", "bad.toml", "-o", "out/d"],
    "export": ["export", "sjob.toml", "-o", "out/e"],
    "review": ["review", "bad.toml", "--shots", "shots"],
    "scene-asbuilt": ["scene", "asbuilt", "bad.toml", "-o", "out/a"],
}
MANIFEST_CASES += [
    case(
        f"{reader}-manifest-translate=nan",
        args,
        ["bad.toml", "translate must be three finite numbers"],
        {
            "bad.toml": manifest(part="translate = [0, nan, 0]"),
            "sjob.toml": job().replace('"scene.toml"', '"bad.toml"'),
        },
    )
    for reader, args in OTHER_SCENE_READERS.items()
]

# -- scans, suggestions -------------------------------------------------------------------------------------
PLY = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
SCAN_CASES = [
    case(
        f"deviation-scan-{name}",
        ["deviation", name, "--scene", "scene.toml", "-o", "out/d"],
        [name, "1 points with NaN or infinite coordinates"],
        {name: content},
    )
    for name, content in [
        ("nan.xyz", "0 0 0.5\n0.1 nan 0.5\n0.2 0 0.5\n"),
        ("inf.xyz", "0 0 0.5\n0.1 0 inf\n"),
        ("nan.ply", PLY + "0 0 0.5\n0.1 nan 0.5\n0.2 0 0.5\n"),
    ]
]
SCAN_CASES += [
    case(
        "deviation-scan-decimal-commas",
        ["deviation", "dec.xyz", "--scene", "scene.toml", "-o", "out/d"],
        ["dec.xyz", "line 2", "1,25 2,50 0,10", "decimal commas are not supported"],
        {"dec.xyz": "0.1 0.2 0.5\n1,25 2,50 0,10\n"},
    ),
    case(
        "deviation-scan-one-decimal-comma",
        ["deviation", "dec.xyz", "--scene", "scene.toml", "-o", "out/d"],
        ["dec.xyz", "line 1", "decimal commas are not supported"],
        {"dec.xyz": "0,1 0.2 0.5\n0.1 0.2 0.5\n"},
    ),
]
SUGGESTION_CASES = [
    case(
        f"review-suggestion-{key}={text(v)}",
        ["review", "scene.toml", "--shots", "shots", "--suggestions", "s=sugg.json"],
        ["sugg.json", f"suggested marker 1: {key} (photo pixels): {text(v)} is not a finite number"],
        {"sugg.json": {"suggested_markers": [{"x": 10.0, "y": 10.0, **{key: v}}]}},
    )
    for key in ("x", "y")
    for v in (NAN, INF)
]

CASES = (
    OPTION_CASES
    + BOARD_CASES
    + CAMERA_CASES
    + REGISTRATION_CASES
    + JOB_CASES
    + MANIFEST_CASES
    + SCAN_CASES
    + SUGGESTION_CASES
)


@pytest.mark.parametrize("args, fragments, files", CASES)
def test_nan_and_infinity_are_refused(project, capsys, args, fragments, files):
    run_refused(capsys, args, files, *fragments)


# mrcheck regress exits 2 on bad input (1 says a view changed): its cases have their own test
REGRESS_OPTION_CASES = [
    case(
        f"regress-check{option}={text(v)}",
        ["regress", "check", "scene.toml", "--baseline", "b", "-o", "out/r", option, text(v)],
        [option, f"{text(v)} is not a finite number"],
    )
    for option in ("--max-mean", "--max-p999", "--pixel-flip", "--max-changed")
    for v in BAD
]


@pytest.mark.parametrize("args, fragments, files", REGRESS_OPTION_CASES)
def test_nan_and_infinity_are_refused_by_regress_with_exit_2(project, capsys, args, fragments, files):
    before = snapshot()
    rc = main(args)
    captured = capsys.readouterr()
    assert rc == 2 and captured.out == "" and captured.err.count("\n") == 1, (rc, captured)
    assert captured.err.startswith("error: ") and all(f in captured.err for f in fragments), captured.err
    assert snapshot() == before


@pytest.mark.slow
def test_a_nan_in_one_shot_of_an_export_fails_that_shot_only(project, capsys):
    """A shot's own SHOT.json is read when the shot runs: a NaN there fails that shot, named with
    its file and the problem, and the other shots are exported."""
    write_files(
        {
            "bad.json": shot(t=[0, NAN, 5]),
            "ejob.toml": job(
                '[[shots]]\nname = "good"\nshot = "shot.json"\n[[shots]]\nname = "bad"\nshot = "bad.json"\n'
            ),
        }
    )
    assert main(["export", "ejob.toml", "-o", "out"]) == 1
    out = capsys.readouterr().out
    assert "failed bad:" in out and "bad.json: camera t contains NaN or infinite values" in out, out
    assert sorted(p.name for p in Path("out/shots/bad").iterdir()) == ["record.json"]
    assert (Path("out/shots/good") / "sheet.png").is_file()


@pytest.mark.parametrize("rms", [NAN, INF])
def test_an_export_writes_no_nan_of_a_given_shot(project, capsys, rms):
    """A given SHOT.json's "rms" is what the registration measured, shown, not used: NaN is an
    unknown registration error (as the review shows it), not NaN in manifest.json, record.json
    and the copied SHOT.json, which no JSON reader but Python's takes."""
    write_files({"nan.json": shot(rms=rms), "ejob.toml": job('[[shots]]\nname = "s"\nshot = "nan.json"\n')})
    assert main(["export", "ejob.toml", "-o", "out"]) == 0, capsys.readouterr().err

    def strict(text):
        return json.loads(text, parse_constant=lambda name: pytest.fail(f"{name} in an output"))

    manifest_json = strict(Path("out/manifest.json").read_text())
    assert manifest_json["shots"][0]["registration_error_px"] is None
    strict(Path("out/shots/s/record.json").read_text())
    assert strict(Path("out/shots/s/SHOT.json").read_text())["rms"] is None


@pytest.mark.parametrize(
    "content", ["0.1,0.2,0.5\n0.2,0.1,0.5\n", "0.1, 0.2, 0.5\n", "0.1;0.2;0.5\n", "# x, y z\n0.1 0.2 0.5\n"]
)
def test_comma_separated_scans_still_read(project, capsys, content):
    """x,y,z (CloudCompare's ASCII export), with spaces or semicolons, and a comment line with
    commas: read, not taken for decimal commas."""
    Path("ok.xyz").write_text(content)
    assert main(["deviation", "ok.xyz", "--scene", "scene.toml", "-o", "out"]) == 0, capsys.readouterr().err
    assert len(np.load("out/deviations.npy")) == content.count("0.1")


def test_the_cases_cover_every_float_option():
    """A float option added to the CLI without a case here is a failure of this test."""
    from mrcheck.cli import cli
    from mrcheck.cli.options import FINITE

    def commands(group, prefix=()):
        for name, command in group.commands.items():
            if hasattr(command, "commands"):
                yield from commands(command, (*prefix, name))
            else:
                yield " ".join((*prefix, name)), command

    floats = {
        (name, opt)
        for name, command in commands(cli)
        for p in command.params
        if p.type is FINITE
        for opt in p.opts
        if opt.startswith("--")
    }
    covered = set()
    for param in OPTION_CASES + REGRESS_OPTION_CASES:
        args = param.values[0]
        name = f"{args[0]} {args[1]}" if args[0] in ("scene", "regress") else args[0]
        covered |= {(name, a) for a in args if a.startswith("--")}
    assert floats and floats <= covered, sorted(floats - covered)
