"""Issue 21: anti-aliasing against a 4x4 supersampled render, the tone curve on every shipped
scene, and the vector mode's default strength against the ray-traced reference.

Each test records what it measured (``record_property``) and prints it (``pytest -s``).
"""

from __future__ import annotations

import numpy as np
import pytest

from mrcheck.core.resources import sample_scene_path, shipped_scene
from mrcheck.eval.aa_reference import image_mae, supersampled_reference
from mrcheck.eval.reference import REFERENCE_LOD_PX, reference_ao
from mrcheck.render.renderer import Renderer, RenderSettings
from mrcheck.scene.model import load_scene

pytestmark = pytest.mark.slow  # every test here is slow (tests/conftest.py)

SCENES = {
    "sample": sample_scene_path(),
    "cell": shipped_scene("cell"),
    "line": shipped_scene("line"),
}
STUDY = ["phong", "vector", "ssao"]


@pytest.fixture(scope="module")
def renderers(ctx):
    made = {name: Renderer(load_scene(path), ctx=ctx) for name, path in SCENES.items()}
    yield made
    for renderer in made.values():
        renderer.release()


# -- anti-aliasing ---------------------------------------------------------------------------------
@pytest.mark.parametrize("scene, view", [("sample", "robot"), ("cell", "aisle"), ("cell", "robot_cell")])
def test_antialiasing_halves_the_error_against_a_4x4_supersampled_render(renderers, scene, view, record_property):
    """Mean absolute error (grey levels) of the image against the same view rendered at 4x4 the
    pixels and area-averaged, without and with anti-aliasing (4x MSAA, mrcheck.render.antialias).
    Measured at 256x192 on these views (every view at 512x384 and 1024x768: docs/rendering.md):
    Phong 0.15-0.18 of the error without, vector 0.24-0.44, ssao 0.27-0.48 (on the two overview
    views, not tested here, ssao is 0.57-0.59 at this size: its AO's own noise at one sample per
    pixel, which the 4x4 render averages away; at most 0.49 at the larger sizes). Limits: Phong 0.3,
    vector and ssao 0.5 (the issue's half)."""
    renderer = renderers[scene]
    camera = renderer.scene.camera(view, 256, 192)
    reference = supersampled_reference(renderer, camera, STUDY)
    without = renderer.render(camera, STUDY, RenderSettings(antialias=False))
    with_aa = renderer.render(camera, STUDY, RenderSettings())
    for mode in STUDY:
        before, after = image_mae(without[mode].image, reference[mode]), image_mae(with_aa[mode].image, reference[mode])
        record_property(mode, f"{before:.2f} -> {after:.2f}")
        print(f"{scene} {view} {mode}: MAE {before:.2f} -> {after:.2f} ({after / before:.2f})")
        assert after / before < {"phong": 0.3, "vector": 0.5, "ssao": 0.5}[mode]


# -- light and tone --------------------------------------------------------------------------------
def _cad_stats(frame) -> tuple[float, float, float]:
    """(share of CAD pixels with a channel >= 250, mean |D2 - D1| and |D3 - D1| over the CAD, levels)."""
    covered = frame.depth > 0
    images = {m: frame[m].image.astype(np.float32) for m in STUDY}
    saturated = float((images["phong"].max(axis=2) >= 250)[covered].mean())
    d2 = float(np.abs(images["vector"] - images["phong"]).mean(axis=2)[covered].mean())
    d3 = float(np.abs(images["ssao"] - images["phong"]).mean(axis=2)[covered].mean())
    return saturated, d2, d3


@pytest.mark.parametrize("scene", list(SCENES))
def test_light_surfaces_stay_below_saturation_and_the_modes_differ(renderers, scene, record_property):
    """Every view of every shipped scene (the demo's study sheets, at 256x192): with the filmic
    tone no CAD pixel reaches 250 of 255 (measured 0 % everywhere; with ``tone="clip"``, the
    renders before, up to 0.9 % of a view), and D2 and D3 each differ from D1 by >= 1.2 grey
    levels on average over the CAD (measured D2 1.41-4.43, D3 2.05-7.80; the AO acts at creases
    and contacts, most of the CAD is open surface)."""
    renderer = renderers[scene]
    clipped = []
    for view in sorted(renderer.scene.viewpoints):
        camera = renderer.scene.camera(view, 256, 192)
        saturated, d2, d3 = _cad_stats(renderer.render(camera, STUDY, RenderSettings()))
        clipped.append(_cad_stats(renderer.render(camera, STUDY, RenderSettings(tone="clip")))[0])
        record_property(view, f"saturated {saturated:.2%}, D2-D1 {d2:.2f}, D3-D1 {d3:.2f}")
        print(f"{scene} {view}: saturated {saturated:.2%} (clip {clipped[-1]:.2%}), |D2-D1| {d2:.2f}, |D3-D1| {d3:.2f}")
        assert saturated == 0.0
        assert d2 >= 1.2 and d3 >= 1.2
    assert max(clipped) > 0.0  # the premise: without the curve, light surfaces saturate


# -- the vector mode's default strength --------------------------------------------------------------
@pytest.mark.parametrize("scene", ["sample", "cell"])
def test_default_vector_darkening_matches_the_ray_traced_reference(renderers, scene, record_property):
    """sum(1 - AO) of the vector mode at its default strength over that of the ray-traced reference
    of the same screen radius, pooled over every view of the scene (512x384, 16 rays). Measured
    at 512x384 with 64 rays (docs/rendering.md): 0.80 at intensity 1 on both scenes, 1.00 at the
    default 1.25 (the views 0.88-1.10). Limits 0.9-1.1, the issue's 10 %. The match depends on the
    radius in pixels: at 256x192 (a 3.8 px radius) the ratio is 0.79 / 0.73."""
    renderer = renderers[scene]
    mode_sum = reference_sum = 0.0
    for view in sorted(renderer.scene.viewpoints):
        camera = renderer.scene.camera(view, 512, 384)
        settings = RenderSettings(antialias=False, lod_px=REFERENCE_LOD_PX).validated(camera.height)
        frame = renderer.render(camera, ["vector"], settings, want_ao=True, want_normals=True)
        ref = reference_ao(
            renderer.scene,
            camera,
            frame.depth,
            frame.normals,
            16,
            "screen",
            settings.radius_px,
            falloff=settings.falloff,
            seed=1,
        )
        covered = frame.depth > 0
        mode_sum += float((1.0 - frame["vector"].ao[covered]).sum())
        reference_sum += float((1.0 - ref[covered]).sum())
    ratio = mode_sum / reference_sum
    record_property("ratio", ratio)
    print(f"{scene}: vector darkening / reference {ratio:.3f}")
    assert 0.9 < ratio < 1.1
