"""Golden-image regression tests: every mode on the embedded sample scene.

Compared with a tolerance (llvmpipe versions may differ in the last bit); on failure the test
writes ``tests/_failures/<name>_{actual,golden,diff}.png`` (diff amplified 8x) and says where.
Each case first removes its own images of an earlier failed run.

Update the goldens after an intended change, then look at them before committing:

    MRCHECK_UPDATE_GOLDEN=1 ./bootstrap.sh test tests/test_golden.py
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from mrcheck.core.resources import sample_scene_path
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.model import load_scene

GOLDEN = Path(__file__).parent / "golden"
FAILURES = Path(__file__).parent / "_failures"
UPDATE = os.environ.get("MRCHECK_UPDATE_GOLDEN") == "1"
W, H = 320, 240

# (mean absolute difference, share of pixels allowed to differ by more than 8/255)
TOLERANCE = (1.0 / 255.0, 0.005)

CASES = {
    # name: (view, mode, settings, what is compared)
    "overview_phong": ("overview", "phong", {}, "image"),
    "overview_vector": ("overview", "vector", {}, "image"),
    "overview_ssao": ("overview", "ssao", {}, "image"),
    "robot_vector_ao_raw": ("robot", "vector", {"blur": False, "samples": 36}, "ao"),
    "robot_ssao_ao_raw": ("robot", "ssao", {"blur": False, "samples": 36}, "ao"),
    "robot_vector_half_res": ("robot", "vector", {"ao_scale": 0.5, "blur_size": 13}, "image"),
    "conveyor_vector_sun_direct": (
        "conveyor",
        "vector",
        {"light": "sun", "ao_direct": True, "intensity": 2.0},
        "image",
    ),
    "overview_crytek": ("overview", "crytek", {}, "image"),
    "overview_hbao": ("overview", "hbao", {}, "image"),
    "overview_alchemy": ("overview", "alchemy", {}, "image"),
    "robot_hbao_ao_raw": ("robot", "hbao", {"blur": False, "samples": 36}, "ao"),
    "overview_gtao": ("overview", "gtao", {}, "image"),
    "overview_vbao": ("overview", "vbao", {}, "image"),
    "robot_gtao_ao_raw": ("robot", "gtao", {"blur": False, "samples": 36}, "ao"),
    "robot_vbao_ao_raw": ("robot", "vbao", {"blur": False, "samples": 36}, "ao"),
}


@pytest.fixture(scope="module")
def renderer(ctx):
    return Renderer(load_scene(sample_scene_path()), ctx=ctx)


def _as_8bit(result, what) -> np.ndarray:
    if what == "ao":
        return np.round(result.ao * 255.0).astype(np.uint8)
    return result.image[..., ::-1]  # BGR for OpenCV


@pytest.mark.parametrize("name", sorted(CASES))
def test_golden(renderer, name):
    view, mode, settings, what = CASES[name]
    # an earlier failed run's images of this case would read as a current failure
    for stale in FAILURES.glob(f"{name}_*.png"):
        if stale.stem.rsplit("_", 1)[0] == name:  # overview_vector_*, not overview_vector_sun_*
            stale.unlink()
    camera = renderer.scene.camera(view, W, H)
    result = renderer.render(camera, [mode], RenderSettings(**settings), want_ao=what == "ao")[mode]
    actual = _as_8bit(result, what)
    path = GOLDEN / f"{name}.png"
    if UPDATE:
        GOLDEN.mkdir(exist_ok=True)
        cv2.imwrite(str(path), actual)
        pytest.skip(f"golden updated: {path}")
    assert path.exists(), f"no golden image {path}; create it with MRCHECK_UPDATE_GOLDEN=1"
    golden = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert golden.shape == actual.shape
    diff = np.abs(actual.astype(np.int16) - golden.astype(np.int16))
    mean, share = diff.mean() / 255.0, (diff > 8).mean()
    if mean > TOLERANCE[0] or share > TOLERANCE[1]:
        FAILURES.mkdir(exist_ok=True)
        for suffix, image in (
            ("actual", actual),
            ("golden", golden),
            ("diff", np.clip(diff * 8, 0, 255).astype(np.uint8)),
        ):
            cv2.imwrite(str(FAILURES / f"{name}_{suffix}.png"), image)
        pytest.fail(
            f"{name}: mean difference {mean:.4f}, {share:.2%} of pixels off by > 8/255; see {FAILURES}/{name}_diff.png"
        )


def test_golden_comparison_catches_a_change(renderer):
    # the comparison itself must be able to fail: a darker AO is far outside the tolerance
    view, mode, settings, what = CASES["overview_vector"]
    camera = renderer.scene.camera(view, W, H)
    stronger = renderer.render(camera, [mode], RenderSettings(intensity=4.0))[mode].image[..., ::-1]
    golden = cv2.imread(str(GOLDEN / "overview_vector.png"))
    diff = np.abs(stronger.astype(np.int16) - golden.astype(np.int16))
    assert diff.mean() / 255.0 > TOLERANCE[0] or (diff > 8).mean() > TOLERANCE[1]


def test_a_passing_case_removes_its_stale_failure_images(renderer):
    """Failure images of an earlier failed run stayed in tests/_failures after later passing runs,
    where they read as a current failure. Each case clears its own (a -k subset leaves the rest)."""
    FAILURES.mkdir(exist_ok=True)
    stale = [FAILURES / f"overview_phong_{suffix}.png" for suffix in ("actual", "golden", "diff")]
    other = FAILURES / "not_a_case_of_this_run_diff.png"
    for path in [*stale, other]:
        path.write_bytes(b"stale")
    try:
        test_golden(renderer, "overview_phong")
        assert not any(path.exists() for path in stale)
        assert other.exists()
    finally:
        other.unlink(missing_ok=True)
        for path in stale:
            path.unlink(missing_ok=True)
