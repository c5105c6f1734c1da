"""No command overwrites one of its inputs: an output that is an input (the same file, through a
symlinked file or folder too; for an output folder, a file the command writes there) is refused
before any work, as ``error: OUTPUT: the output would overwrite the input INPUT (ROLE) ...``.

Every case runs the real command line in-process (``mrcheck.cli.main``) in a fresh project
folder and checks the whole contract: exit 1, exactly one stderr line ``error: ...`` naming the
input and saying it is one, no traceback, nothing on stdout, and every file of the folder (inputs,
links) byte for byte as before, with no new file.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import trimesh

from mrcheck.cli import main

from .project_files import (  # noqa: F401 (a fixture)
    PHOTO,
    Link,
    camera,
    correspondences,
    job,
    manifest,
    project,
    run_refused,
    shot,
    write_files,
)

# OpenCV's chessboard samples (tests/data/calibration): a calibration that succeeds
BOARD_PHOTOS = sorted(
    str(p) for p in (Path(__file__).parent / "data/calibration/opencv_chessboard").glob("left[0-9]*.jpg")
)
TEXTURED = ("tex.toml", "--view", "v")  # the project's box as an OBJ with a texture map, from viewpoint "v"


def textured(texture: str) -> dict:
    """tex.toml: the box as tex.obj, whose material's texture map is ``texture`` (a PNG)."""
    box = trimesh.creation.box()
    obj = (
        "mtllib tex.mtl\nusemtl m\n"
        + "".join(f"v {x} {y} {z}\n" for x, y, z in box.vertices)
        + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in box.faces)
    )
    return {
        "tex.toml": manifest("tex.obj"),
        "tex.obj": obj,
        "tex.mtl": f"newmtl m\nKd 1 1 1\nmap_Kd {texture}\n",
        texture: PHOTO,
    }


def export_manifest() -> dict:
    """An export folder's manifest.json: one done shot, shots/s/SHOT.json."""
    return {
        "format": 1,
        "settings": {"scene": "scene.toml"},
        "shots": [{"name": "s", "status": "done", "folder": "shots/s"}],
    }


def case(id, args, names, files=None):
    """``args`` after ``mrcheck``; ``names``: the input the message must name; ``files``: the
    case's own files besides the project's."""
    return pytest.param(list(args), names, files or {}, id=id)


CASES = [
    # -- render / reference: an image or AO output that is a file of the scene (a texture) ---------------
    case("render-o-texture", ["render", *TEXTURED, "-o", "tex.png"], "tex.png", textured("tex.png")),
    case(
        "render-output-ao-texture",
        ["render", *TEXTURED, "-o", "out/r.png", "--output-ao", "tex.png"],
        "tex.png",
        textured("tex.png"),
    ),
    case(
        "render-o-texture-via-linked-folder",
        ["render", *TEXTURED, "-o", "linkdir/tex.png"],
        "tex.png",
        textured("tex.png"),
    ),
    case(
        "render-o-camera-via-link",
        ["render", "scene.toml", "--camera", "cam.png", "-o", "view.png"],
        "cam.png",
        {"cam.png": camera().to_dict(), "view.png": Link("cam.png")},
    ),
    case(
        "reference-o-texture", ["reference", *TEXTURED, "--rays", "4", "-o", "tex.png"], "tex.png", textured("tex.png")
    ),
    case(
        "reference-o-texture-via-linked-folder",
        ["reference", *TEXTURED, "--rays", "4", "-o", "linkdir/tex.png"],
        "tex.png",
        textured("tex.png"),
    ),
    # -- overlay -------------------------------------------------------------------------------------------
    case("overlay-o-photo", ["overlay", "shot.json", "--scene", "scene.toml", "-o", "photo.png"], "photo.png"),
    case(
        "overlay-o-photo-via-linked-folder",
        ["overlay", "shot.json", "--scene", "scene.toml", "-o", "linkdir/photo.png"],
        "photo.png",
    ),
    case(
        "overlay-o-texture",
        ["overlay", "shot.json", "--scene", "tex.toml", "-o", "tex.png"],
        "tex.png",
        textured("tex.png"),
    ),
    # -- register: -o is the correspondences, the intrinsics, the marker map ---------------------------------
    *(
        case(
            f"register-o-{name}",
            ["register", "scene.toml", "--photo", "photo.png", "--intrinsics", "intr.json", *method, "-o", out],
            target,
        )
        for name, method, out, target in [
            ("points", ["--points", "corr.json"], "corr.json", "corr.json"),
            ("intrinsics", ["--points", "corr.json"], "intr.json", "intr.json"),
            ("markers", ["--markers", "markers.json"], "markers.json", "markers.json"),
            ("points-via-linked-folder", ["--points", "corr.json"], "linkdir/corr.json", "corr.json"),
            ("points-via-link", ["--points", "corr.json"], "alias.json", "corr.json"),
        ]
    ),
    # -- calibrate: a glob of the folder takes in the camera file that -o would replace ---------------------------
    case(
        "calibrate-o-image",
        ["calibrate", *BOARD_PHOTOS, "old.json", "--board", "chessboard:9x6:0.025", "-o", "old.json"],
        "old.json",
        {"old.json": camera().to_dict()},
    ),
    case(
        "calibrate-o-image-via-linked-folder",
        ["calibrate", *BOARD_PHOTOS, "old.json", "--board", "chessboard:9x6:0.025", "-o", "linkdir/old.json"],
        "old.json",
        {"old.json": camera().to_dict()},
    ),
    # -- output folders: a file the command writes into OUTDIR is an input ------------------------------------------
    case(
        "compare-outdir-texture",
        ["compare", *TEXTURED[:1], "--view", "v", "--rays", "4", "--samples", "4", "-o", "out"],
        "figure.png",
        textured("out/figure.png"),
    ),
    case(
        "compare-outdir-texture-via-linked-folder",
        ["compare", *TEXTURED[:1], "--view", "v", "--rays", "4", "-o", "linkout"],
        "figure.png",
        textured("out/figure.png"),
    ),
    case(
        "deviation-outdir-photo",
        ["deviation", "scan.xyz", "--scene", "scene.toml", "--shot", "dshot.json", "-o", "out"],
        "deviation_overlay.png",
        {"dshot.json": shot("out/deviation_overlay.png"), "out/deviation_overlay.png": PHOTO},
    ),
    case(
        "deviation-outdir-shot-via-linked-folder",
        ["deviation", "scan.xyz", "--scene", "scene.toml", "--shot", "out/parts.json", "-o", "linkout"],
        "parts.json",
        {"out/parts.json": shot("../photo.png")},
    ),
    case(
        "discrepancies-outdir-photo",
        ["discrepancies", "dshot.json", "--scene", "scene.toml", "-o", "out"],
        "heatmap.png",
        {"dshot.json": shot("out/heatmap.png"), "out/heatmap.png": PHOTO},
    ),
    case(
        "discrepancies-outdir-shot-via-linked-folder",
        ["discrepancies", "out/suspects.json", "--scene", "scene.toml", "-o", "linkout"],
        "suspects.json",
        {"out/suspects.json": shot("../photo.png")},
    ),
    case(
        "export-outdir-photo",
        ["export", "ejob.toml", "-o", "out"],
        "render_phong.png",
        {
            "ejob.toml": job('[[shots]]\nname = "s"\nshot = "eshot.json"\n'),
            "eshot.json": shot("out/shots/s/render_phong.png"),
            "out/shots/s/render_phong.png": PHOTO,
        },
    ),
    case(
        "export-outdir-points",
        ["export", "ejob.toml", "-o", "out"],
        "manifest.json",
        {
            "ejob.toml": job(
                '[[shots]]\nphoto = "photo.png"\nintrinsics = "intr.json"\npoints = "out/manifest.json"\n'
            ),
            "out/manifest.json": correspondences(),
        },
    ),
    case(
        "export-outdir-photo-via-linked-folder",
        ["export", "ejob.toml", "-o", "linkout"],
        "render_phong.png",
        {
            "ejob.toml": job('[[shots]]\nname = "s"\nshot = "eshot.json"\n'),
            "eshot.json": shot("out/shots/s/render_phong.png"),
            "out/shots/s/render_phong.png": PHOTO,
        },
    ),
    # -- review: --db is an input ------------------------------------------------------------------------------------
    case("review-db-job", ["review", "job.toml", "--db", "job.toml"], "job.toml"),
    case("review-db-photo", ["review", "scene.toml", "--shots", "shots", "--db", "photo.png"], "photo.png"),
    case(
        "review-db-shot-via-linked-folder",
        ["review", "scene.toml", "--shots", "shots", "--db", "linkdir/shots/s.json"],
        "s.json",
    ),
    case(
        "review-db-suggestions",
        ["review", "scene.toml", "--shots", "shots", "--suggestions", "s=sugg.json", "--db", "sugg.json"],
        "sugg.json",
        {"sugg.json": {"suggested_markers": []}},
    ),
    case(
        "review-db-export-manifest",
        ["review", "exp", "--db", "exp/manifest.json"],
        "manifest.json",
        {"exp/manifest.json": export_manifest(), "exp/shots/s/SHOT.json": shot("../../../photo.png")},
    ),
    case("review-db-scene-mesh", ["review", "job.toml", "--db", "box.stl"], "box.stl"),
    # -- scene asbuilt: an earlier variant in OUTDIR holds a mesh of the planned scene, which replacing it deletes ----
    case(
        "asbuilt-outdir-holds-a-planned-mesh",
        ["scene", "asbuilt", "planned/scene.toml", "-o", "variant"],
        "box.stl",
        {
            "planned/scene.toml": 'format = 1\n[[parts]]\nname = "floor"\nmesh = "floor.stl"\nunits = "m"\n[[parts]]\n'
            'name = "crate"\nmesh = "../variant/box.stl"\nunits = "m"\ntranslate = [0, 0, 0.55]\n',
            "planned/floor.stl": lambda p: trimesh.creation.box(extents=(10, 10, 0.1)).export(p),
            "variant/scene.toml": 'format = 1\n[[parts]]\nname = "crate"\nmesh = "box.stl"\nunits = "m"\n',
            "variant/discrepancies.json": {"discrepancies": []},
            "variant/box.stl": lambda p: trimesh.creation.box().export(p),
        },
    ),
]


@pytest.mark.parametrize("args, names, files", CASES)
def test_an_output_that_is_an_input_is_refused(project, capsys, args, names, files):
    err = run_refused(capsys, args, files, "the input", names)  # every input (and link) as it was
    assert err.count("\n") == 1, err


def test_the_project_is_a_working_one(project, capsys):
    """The harness is not vacuous: the project's files work as inputs, and an output beside them
    that is none of them is written (register, and an overlay over the textured scene)."""
    write_files(textured("tex.png"))
    assert (
        main(
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
                "new.json",
            ]
        )
        == 0
    ), capsys.readouterr().err
    assert main(["overlay", "shot.json", "--scene", "tex.toml", "-o", "over.png"]) == 0, capsys.readouterr().err
    assert Path("new.json").is_file() and Path("over.png").is_file()


def test_an_output_folder_beside_its_inputs_is_fine(project, capsys):
    """An output folder beside the inputs is written; the inputs' own folder, which holds the
    user's files, is refused (an output folder is new, empty or one mrcheck made)."""
    assert main(["discrepancies", "shot.json", "--scene", "scene.toml", "-o", "results"]) == 0, capsys.readouterr().err
    assert Path("results/heatmap.png").is_file() and Path("photo.png").is_file()
    assert main(["discrepancies", "shot.json", "--scene", "scene.toml", "-o", "."]) == 1
    assert "output folder holds other files and was not made by mrcheck" in capsys.readouterr().err
    assert not Path("heatmap.png").exists()
