"""Copy the four industrial robot models from their source packages into this folder.

Run once by hand (``python factory_scenes/assets/robots/build_robot_assets.py [DATA_DIR]``,
default ``/work/shared/data/robots``); the copies it makes are committed, so the project
never needs the source packages. Each robot gets ``<name>/robot.urdf``, the visual meshes
the URDF names and its licence file; ``SOURCE.md`` beside them says what was changed.

Only visual meshes are copied: mrcheck renders visuals and loads URDFs with
``load_collision_meshes=False``. Where a URDF is rewritten anyway (UR5, UR10, IRB 140), its
``<collision>`` elements are removed (their meshes are not shipped; the UR's one other is a
1 cm box on a frame without visuals), so the copy names no file it does not have. The KUKA
URDF is copied unchanged (its collision ``.stl`` files are simply never opened), exactly as
in ``factory_scenes/sample_cell/robots``. The ``SOURCE.md`` files and the IRB 140's
``LICENSE`` are written by hand, not by this script.
"""

from __future__ import annotations

import re
import shutil
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
DEFAULT_DATA = Path("/work/shared/data/robots")

# The rtb-data IRB 140 meshes and URDF origins are authored in a unit of 0.254 m (10 in,
# apparently a Blender scene scale): joint 2 sits 1.38 units up and 0.28 out, the arms are
# 1.42 and 1.49 long, against 352, 70, 360 and 380 mm in ABB's IRB 140 data sheet (all four
# within 0.5 % at 0.254 m per unit). Loaded as authored the robot would stand 3.2 m tall.
IRB140_METRES_PER_UNIT = 0.254

_COLLISION = re.compile(r"[ \t]*<collision>.*?</collision>[ \t]*\n", re.S)  # collision elements never nest


def _drop_collisions(text: str) -> str:
    return _COLLISION.sub("", text)


def _add_note(text: str, note: str) -> str:
    """``note`` as an XML comment right after the XML declaration (which must stay first)."""
    comment = "<!-- mrcheck copy: " + note + " -->\n"
    if text.startswith("<?xml"):
        end = text.index("?>") + 2
        return text[:end] + "\n" + comment + text[end:].lstrip("\n")
    return comment + text


def _copy(src: Path, dst: Path):
    dst.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(src, dst)


def build_kuka(data: Path, out: Path):
    src = data / "pybullet_data" / "kuka_iiwa"
    _copy(src / "model.urdf", out / "robot.urdf")  # unchanged: its mesh paths are already relative
    for i in range(8):
        for ext in ("obj", "mtl"):
            _copy(src / "meshes" / f"link_{i}.{ext}", out / "meshes" / f"link_{i}.{ext}")
    _copy(data / "pybullet_data" / "LICENSE.txt", out / "LICENSE.txt")


def build_ur(data: Path, out: Path, model: str):
    src = data / "example_robot_data" / "ur_description"
    text = (src / "urdf" / f"{model}_robot.urdf").read_text()
    text = _drop_collisions(text)
    text = text.replace(f"package://example-robot-data/robots/ur_description/meshes/{model}/visual/", "meshes/visual/")
    if "package://" in text:
        raise SystemExit(f"{model}: package:// paths left after rewriting")
    text = _add_note(
        text,
        "visual mesh paths made relative (meshes/visual/...), all <collision> elements "
        "removed (the collision meshes are not shipped); otherwise as in example-robot-data 6.0.0.",
    )
    (out / "robot.urdf").write_text(text)
    for mesh in sorted((src / "meshes" / model / "visual").glob("*.dae")):
        _copy(mesh, out / "meshes" / "visual" / mesh.name)
    _copy(data / "example_robot_data" / "LICENSE", out / "LICENSE")


def build_irb140(data: Path, out: Path):
    src = data / "rtb_data" / "abb_irb140_description"
    text = (src / "urdf" / "irb140.urdf").read_text()
    text = _drop_collisions(text)
    text = text.replace("package://abb_irb140_support/meshes/irb140/visual/", "meshes/visual/")
    if "package://" in text:
        raise SystemExit("irb140: package:// paths left after rewriting")
    s = IRB140_METRES_PER_UNIT

    def scale_origin(match):  # joint and visual origins; <axis xyz> are directions and stay
        xyz = " ".join(f"{float(v) * s:.6g}" for v in match.group(2).split())
        return f'{match.group(1)}xyz="{xyz}"'

    text = re.sub(r'(<origin\b[^>]*?)xyz="([^"]*)"', scale_origin, text)
    text = re.sub(r'(<mesh filename="[^"]*")\s*/>', rf'\1 scale="{s} {s} {s}"/>', text)
    text = _add_note(
        text,
        f"metres: every origin xyz multiplied by {s} and every visual mesh given "
        f'scale="{s} {s} {s}" (the source is authored in units of {s} m); '
        "visual mesh paths made relative (meshes/visual/...), all <collision> "
        "elements removed (the collision meshes are not shipped). Source: rtb-data 2.0.0.",
    )
    (out / "robot.urdf").write_text(text)
    for mesh in sorted((src / "meshes" / "irb140" / "visual").glob("*.stl")):
        _copy(mesh, out / "meshes" / "visual" / mesh.name)
    # LICENSE (MIT notice of the Robotics Toolbox for Python) and SOURCE.md are written by hand


def main(argv):
    data = Path(argv[1]) if len(argv) > 1 else DEFAULT_DATA
    for name in ("kuka_iiwa", "ur5", "ur10", "abb_irb140"):
        (HERE / name).mkdir(exist_ok=True)
    build_kuka(data, HERE / "kuka_iiwa")
    build_ur(data, HERE / "ur5", "ur5")
    build_ur(data, HERE / "ur10", "ur10")
    build_irb140(data, HERE / "abb_irb140")


if __name__ == "__main__":
    main(sys.argv)
