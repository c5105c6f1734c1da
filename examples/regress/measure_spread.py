"""Measure the no-change spread behind ``mrcheck regress check``'s default tolerances, and what
a small real change does against them (docs/regress.md's table).

    python examples/regress/measure_spread.py [--width 640 --height 480]

On the sample cell's three viewpoints in phong and vector: renders in fresh processes with
LP_NUM_THREADS 0, 1, 2 (llvmpipe's rasteriser threads: set before the GL context exists) and
with 128-bit instead of 256-bit vectors (LP_NATIVE_VECTOR_WIDTH); then two models of what
another driver may change (one 8-bit step of rounding noise on every channel; the principal
point moved by 1/256 px, llvmpipe's sub-pixel grid); then real changes (the conveyor moved
2 cm, the control cabinet's colour changed a little and a lot). Per row the worst of the six
images: FLIP mean, 99.9th percentile, pixels above FLIP 0.2, and the views the default
tolerances fail.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from mrcheck.apps.regress.compare import Tolerances, compare_images
from mrcheck.core.resources import sample_scene_path

MODES = ("phong", "vector")
CONVEYOR = "translate = [-5.8, -2.5, 0.0]"
CABINET = "color = [0.78, 0.78, 0.75]"


def renders(scene, size, shift=0.0) -> dict:
    """{(view, mode): (H, W, 3) uint8} of every viewpoint, the principal point moved by ``shift`` px."""
    from mrcheck.render.renderer import Renderer, RenderSettings
    from mrcheck.scene.model import load_scene

    loaded = load_scene(scene)
    renderer = Renderer(loaded)
    out = {}
    try:
        for view in sorted(loaded.viewpoints):
            camera = loaded.camera(view, *size)
            if shift:
                K = camera.K.copy()
                K[:2, 2] += shift
                camera = dataclasses.replace(camera, K=K)
            frame = renderer.render(camera, MODES, RenderSettings())
            out.update({(view, m): frame[m].image for m in MODES})
    finally:
        renderer.release()
    return out


def in_subprocess(size, env: dict) -> dict:
    """The renders of a fresh process with ``env`` added (llvmpipe reads it when the context is made)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "r.npz"
        cmd = [sys.executable, __file__, "--render-only", str(out), "--width", str(size[0]), "--height", str(size[1])]
        subprocess.run(cmd, env={**os.environ, **env}, check=True)
        with np.load(out) as data:
            return {tuple(k.split("|")): data[k] for k in data.files}


def edited(folder: Path, old: str, new: str) -> Path:
    shutil.copytree(sample_scene_path().parent, folder)
    manifest = folder / "scene.toml"
    manifest.write_text(manifest.read_text().replace(old, new, 1))
    return manifest


def row(name: str, base: dict, other: dict, tolerances: Tolerances) -> str:
    results = {k: compare_images(k[1], base[k], other[k], tolerances) for k in base}
    mean = max(r.mean for r in results.values())
    high = max(r.high for r in results.values())
    count = max(r.changed_pixels for r in results.values())
    failed = sorted({k[0] for k, r in results.items() if not r.passed})
    return f"| {name} | {mean:.4f} | {high:.3f} | {count} | {', '.join(failed) or 'none'} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--render-only", metavar="OUT.npz", help=argparse.SUPPRESS)
    args = parser.parse_args()
    size = (args.width, args.height)
    if args.render_only:
        images = renders(sample_scene_path(), size)
        np.savez(args.render_only, **{"|".join(k): v for k, v in images.items()})
        return
    tolerances = Tolerances()
    base = in_subprocess(size, {})
    rng = np.random.default_rng(0)
    rounded = {
        k: np.clip(v.astype(int) + rng.integers(-1, 2, v.shape), 0, 255).astype(np.uint8) for k, v in base.items()
    }
    print("| what changed | worst FLIP mean | worst FLIP p99.9 | worst px > 0.2 | views failed |")
    print("|---|---|---|---|---|")
    print(row("nothing (a second run in this process)", base, renders(sample_scene_path(), size), tolerances))
    for env in (
        {"LP_NUM_THREADS": "0"},
        {"LP_NUM_THREADS": "1"},
        {"LP_NUM_THREADS": "2"},
        {"LP_NATIVE_VECTOR_WIDTH": "128"},
    ):
        name = " ".join(f"{k}={v}" for k, v in env.items())
        print(row(name, base, in_subprocess(size, env), tolerances))
    print(row("model: one 8-bit step of rounding noise", base, rounded, tolerances))
    for shift in (1 / 256, 1 / 64, 1 / 16):
        print(
            row(
                f"model: principal point moved {shift:g} px",
                base,
                renders(sample_scene_path(), size, shift),
                tolerances,
            )
        )
    with tempfile.TemporaryDirectory() as tmp:
        changes = [
            ("conveyor moved 2 cm", CONVEYOR, "translate = [-5.78, -2.5, 0.0]"),
            ("cabinet colour 0.78 -> 0.70 (green)", CABINET, "color = [0.78, 0.70, 0.75]"),
            ("cabinet colour -> red", CABINET, "color = [0.8, 0.2, 0.2]"),
        ]
        for i, (name, old, new) in enumerate(changes):
            print(row(name, base, renders(edited(Path(tmp) / str(i), old, new), size), tolerances))


if __name__ == "__main__":
    main()
