"""The plan of a bench run: its sections (a scene's stages, built when the section starts and
freed after it) and the entries of jobs each section measures in turns."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import moderngl

from mrcheck.eval.bench.figures import (
    AO_MODES,
    BLUR_SIZES,
    FRAME_PASSES,
    FRAME_SETTINGS,
    HALL_SEED,
    HALL_TRIANGLES,
    HALL_VIEW,
    PAPER_AO_MS,
    PAPER_BLUR_MS,
    PAPER_MODE,
    PAPER_SIZE,
    QUICK_HALL_TRIANGLES,
    QUICK_SAMPLES,
    RATIO_SAMPLES,
    SCALES,
    SIZES,
    TRIANGLE_COUNTS,
    Figure,
    millions,
    paper_frame_ms,
)
from mrcheck.eval.bench.line import LineStages, frame_jobs, frame_scales
from mrcheck.eval.bench.peers import PEERS
from mrcheck.eval.bench.scenes import (
    HallGenerator,
    hall_scene_path,
    sample_scene,
    terrain_camera,
    terrain_scene,
)
from mrcheck.eval.bench.timing import Job, Stage, StageGroup
from mrcheck.render.ao.kernel import PAPER_SAMPLE_COUNTS
from mrcheck.render.renderer import Renderer
from mrcheck.scene.model import load_scene


def hall_jobs(group: StageGroup) -> list[list]:
    """The geometry pass of every hall, timed in turns, at each image size; the figure keeps the
    drawn triangles."""
    entries = {}
    for stage, triangles in zip(group.stages, group.triangles):
        w, h = stage.camera.width, stage.camera.height
        figure = Figure(
            "geometry",
            None,
            w,
            h,
            None,
            None,
            stage.label,
            triangles,
            stats={"generated": "hall", "seed": HALL_SEED, "scene_triangles": stage.renderer.scene.triangle_count},
        )

        def draw(stage=stage, figure=figure):
            figure.stats.update(stage.draw_geometry())

        entries.setdefault((w, h), []).append((stage, Job(figure, lambda: None, draw)))
    return list(entries.values())


def pass_jobs(stage: Stage, samples_list) -> list[list]:
    """AO passes, fetch floors, whole frames, blurs and composites of one stage (items 1-3 of the issue)."""
    w, h = stage.camera.width, stage.camera.height
    paper = (w, h) == PAPER_SIZE

    def fig(name, mode=None, samples=None, scale=None, paper_ms=None):
        return Figure(name, mode, w, h, samples, scale, stage.label, paper_ms=paper_ms if paper else None)

    entries = []
    for samples in samples_list:
        # everything a ratio compares at this sample count is timed in turns (see measure)
        # the whole frame of every mode at these settings, with the CLI's default blur: in an
        # entry of its own, so that the AO passes' rounds stay as short as before
        group, frames = [], []
        for mode in AO_MODES:
            for scale in SCALES:
                s = stage.settings(samples, scale)
                paper_ms = PAPER_AO_MS.get((samples, scale)) if mode == PAPER_MODE else None
                group.append(
                    (
                        stage,
                        Job(
                            fig("ao", mode, samples, scale, paper_ms),
                            stage.draw_geometry,
                            lambda m=mode, s=s: stage.ao(m, s),
                        ),
                    )
                )
                figure = fig("frame", mode, samples, scale, paper_frame_ms(mode, (w, h), samples, scale, s.blur_size))
                figure.stats = {"blur": s.blur_size, "passes": FRAME_PASSES}
                frames.append((stage, Job(figure, lambda: None, lambda m=mode, s=s: stage.frame(m, s))))
        for scale in SCALES:
            group.append(
                (
                    stage,
                    Job(
                        fig("fetch_floor", None, samples, scale),
                        stage.draw_geometry,
                        lambda n=samples, sc=scale: stage.fetch_floor(n, sc),
                    ),
                )
            )
        entries += [group, frames]

    for scale in SCALES:

        def with_ao(scale=scale):
            stage.draw_geometry()
            stage.ao("vector", stage.settings(RATIO_SAMPLES, scale))

        for size in BLUR_SIZES:
            paper_ms = PAPER_BLUR_MS.get(size) if scale == 1.0 else None
            entries.append(
                [
                    (
                        stage,
                        Job(
                            fig(f"blur_{size}x{size}", None, None, scale, paper_ms),
                            with_ao,
                            lambda n=size, sc=scale: stage.blur(n, sc),
                        ),
                    )
                ]
            )

        def with_blur(scale=scale, with_ao=with_ao):
            with_ao()
            stage.blur(BLUR_SIZES[0], scale)

        entries.append(
            [(stage, Job(fig("composite", None, None, scale), with_blur, lambda sc=scale: stage.composite(sc)))]
        )
    return entries


def triangle_jobs(group: StageGroup) -> list[list]:
    """Per height field the geometry pass; then the 16-sample vector AO pass of each, timed in
    turns, with the fetch floor on the first (it covers every pixel)."""
    entries, compared = [], []
    for stage, triangles in zip(group.stages, TRIANGLE_COUNTS):
        w, h = stage.camera.width, stage.camera.height
        entries.append(
            [
                (
                    stage,
                    Job(
                        Figure("geometry", None, w, h, None, None, stage.label, triangles),
                        lambda: None,
                        stage.draw_geometry,
                    ),
                )
            ]
        )
        settings = stage.settings()
        compared.append(
            (
                stage,
                Job(
                    Figure("ao", "vector", w, h, RATIO_SAMPLES, 1.0, stage.label, triangles),
                    stage.draw_geometry,
                    lambda st=stage, s=settings: st.ao("vector", s),
                ),
            )
        )
    first, (w, h) = group.stages[0], PAPER_SIZE
    compared.append(
        (
            first,
            Job(
                Figure("fetch_floor", None, w, h, RATIO_SAMPLES, 1.0, first.label, TRIANGLE_COUNTS[0]),
                first.draw_geometry,
                lambda: first.fetch_floor(RATIO_SAMPLES),
            ),
        )
    )
    return entries + [compared]


@dataclass
class Section:
    """Entries sharing one stage (or group of stages); it is built when the section starts and
    freed after it, so each scene is in memory only while its figures are measured."""

    make_stage: Callable[[], Stage]
    jobs: Callable[[object], list]  # -> entries: lists of (stage, job) measured in turns
    count: int  # figures, for the progress bar
    release_after: bool = True  # False while a later section reuses the stage's renderer


def plan(ctx: moderngl.Context, quick: bool, hall: HallGenerator | None, reasons: dict | None = None) -> list[Section]:
    """The bench's sections in the order they run; ``hall`` makes the generated halls (None: a
    plan to count, not to run)."""
    sizes = SIZES[:1] if quick else SIZES
    samples_list = QUICK_SAMPLES if quick else PAPER_SAMPLE_COUNTS
    sections = []
    sample = {}

    def sample_stage(size):
        if not sample:  # one renderer (one upload) for every size of the sample scene
            scene, camera_for, label = sample_scene()
            sample.update(renderer=Renderer(scene, ctx=ctx), camera_for=camera_for, label=label)
        return Stage(sample["renderer"], sample["camera_for"](size), sample["label"])

    # per sample count: AO passes, floors and frames; per scale: blurs and composite
    per_size = len(samples_list) * (2 * len(AO_MODES) + 1) * len(SCALES) + len(SCALES) * (len(BLUR_SIZES) + 1)
    for size in sizes:
        sections.append(
            Section(
                lambda size=size: sample_stage(size),
                lambda st: pass_jobs(st, samples_list),
                per_size,
                release_after=size == sizes[-1],
            )
        )

    def terrain_stages():
        stages = []
        for triangles in TRIANGLE_COUNTS:
            scene = terrain_scene(triangles)
            stages.append(Stage(Renderer(scene, ctx=ctx), terrain_camera(PAPER_SIZE), scene.name))
        return StageGroup(stages)

    sections.append(Section(terrain_stages, triangle_jobs, 2 * len(TRIANGLE_COUNTS) + 1))

    hall_triangles = QUICK_HALL_TRIANGLES if quick else HALL_TRIANGLES

    def hall_stages():  # at both sizes in a quick run too: a few geometry passes, seconds
        stages, budgets = [], []
        for triangles in hall_triangles:
            scene = load_scene(hall_scene_path(hall, triangles))
            renderer, label = Renderer(scene, ctx=ctx), f"{scene.name}_{millions(triangles)}:{HALL_VIEW}"
            for size in SIZES:
                stages.append(Stage(renderer, scene.camera(HALL_VIEW, *size), label))
                budgets.append(triangles)
        return StageGroup(stages, budgets)

    sections.append(Section(hall_stages, hall_jobs, len(hall_triangles) * len(SIZES)))
    reasons = {} if reasons is None else reasons
    sections.append(
        Section(
            lambda: LineStages(ctx, quick, reasons),
            frame_jobs,
            sum(len(frame_scales(size)) for size, _, _ in FRAME_SETTINGS) + len(PEERS),
        )
    )
    return sections


def planned_figures(quick: bool) -> int:
    """How many figures a run plans to measure (the progress bar's total before the peers start:
    a peer that does not start takes its figure off)."""
    return sum(section.count for section in plan(None, quick, None))


__all__ = ["Section", "plan", "planned_figures", "pass_jobs", "triangle_jobs", "hall_jobs"]
