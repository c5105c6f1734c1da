"""The bench's results: the issue's ratios (paired within one run), the table and the text
``mrcheck bench`` prints."""

from __future__ import annotations

import os
import platform
from statistics import median

import moderngl
import numpy as np

from mrcheck.eval.bench.figures import (
    EVERY_SAMPLE_COUNT,
    PAPER_SIZE,
    PEER_BLUR,
    PEER_RATIOS,
    PEER_SAMPLES,
    PEER_SIZE,
    PEER_TARGETS,
    RATIO_SAMPLES,
    REASON,
    TARGETS,
    TRIANGLE_COUNTS,
    Figure,
)


def find(figures, **match) -> Figure:
    hits = [f for f in figures if all(getattr(f, k) == v for k, v in match.items())]
    if len(hits) != 1:
        raise LookupError(f"expected one figure for {match}, found {len(hits)}")
    return hits[0]


def per_round_ratios(a: Figure, b: Figure) -> list[float] | None:
    """The per-round ratios a / b of two figures timed in turns (one entry), in round order;
    None for figures timed apart."""
    if a.entry is not None and a.entry == b.entry and len(a.times_ms) == len(b.times_ms):
        return [x / y for x, y in zip(a.times_ms, b.times_ms)]
    return None


def paired(a: Figure, b: Figure) -> tuple[float, list[float] | None]:
    """(a / b, its per-round ratios). For figures timed in turns (one entry), the median of the
    per-round ratios: a paired estimate, so that the machine speeding up or slowing down during
    the entry (seen: 10-20 % within one entry) cannot tilt it, as it can a ratio of two medians
    taken from different rounds. Otherwise the ratio of the medians (and no rounds)."""
    per_round = per_round_ratios(a, b)
    return (float(median(per_round)) if per_round else a.median_ms / b.median_ms), per_round


def ratio(a: Figure, b: Figure) -> float:
    return paired(a, b)[0]


def floor_ratios(figures) -> None:
    """Every AO figure over the fetch floor of the same scene, size, sample count and scale,
    timed in turns with it (:func:`ratio`); None where no such floor was measured."""
    floors = {(f.scene, f.width, f.height, f.samples, f.scale): f for f in figures if f.name == "fetch_floor"}
    for f in figures:
        floor = floors.get((f.scene, f.width, f.height, f.samples, f.scale)) if f.name == "ao" else None
        f.over_fetch_floor = None if floor is None else ratio(f, floor)


def ratios(figures, reasons: dict | None = None) -> dict:
    """The issue's ratios (paired within one run, see :func:`ratio`), and the first three at
    every sample count, as the report's ``ratios`` and ``ratios_by_samples``; beside each, its
    per-round ratios (``ratios_rounds``, ``ratios_by_samples_rounds``: how far one round can
    stray from the median). A peer ratio that could not be measured is None, with the peer's
    reason (``reasons``, by peer) beside it as ``<key>_reason``."""
    w, h = PAPER_SIZE

    def ao(mode, samples, scale=1.0, **extra):
        return find(figures, name="ao", mode=mode, samples=samples, scale=scale, width=w, height=h, **extra)

    def floor(samples, triangles):
        return find(figures, name="fetch_floor", samples=samples, scale=1.0, width=w, height=h, triangles=triangles)

    def at(samples):
        vector = ao("vector", samples, triangles=None)
        return {
            "vector_over_ssao": (vector, ao("ssao", samples, triangles=None)),
            "vector_over_fetch_floor": (vector, floor(samples, None)),
            "half_over_full": (ao("vector", samples, 0.5, triangles=None), vector),
        }

    samples_list = sorted(
        {
            f.samples
            for f in figures
            if f.name == "fetch_floor" and (f.width, f.height) == PAPER_SIZE and f.scale == 1.0 and f.triangles is None
        }
    )
    by_samples = {str(n): at(n) for n in samples_list}
    pairs = dict(by_samples[str(RATIO_SAMPLES)])
    few, many = TRIANGLE_COUNTS
    pairs["ao_10m_over_1m"] = (ao("vector", RATIO_SAMPLES, triangles=many), ao("vector", RATIO_SAMPLES, triangles=few))
    pairs["vector_over_fetch_floor_covered"] = (ao("vector", RATIO_SAMPLES, triangles=few), floor(RATIO_SAMPLES, few))

    halls = {
        f.triangles: f
        for f in figures
        if f.name == "geometry" and f.stats.get("generated") == "hall" and (f.width, f.height) == PAPER_SIZE
    }
    pairs["geometry_20m_over_1m"] = (halls[20_000_000], halls[1_000_000])

    pw, ph = PEER_SIZE
    ours = find(figures, name="frame", mode="vector", width=pw, height=ph, samples=PEER_SAMPLES, scale=1.0)
    ours_half = find(figures, name="frame", mode="vector", width=pw, height=ph, samples=PEER_SAMPLES, scale=0.5)
    why = {}
    for peer, key in PEER_RATIOS.items():
        hits = [f for f in figures if f.name == "frame" and f.mode == peer]
        for name, mrcheck_frame in ((key, ours), (key + "_half_res_ao", ours_half)):
            pairs[name] = (hits[0], mrcheck_frame) if hits else None
            if not hits:
                why[name] = (reasons or {}).get(peer, f"no {peer} frame was measured")

    values, per_round = {}, {}
    for name, pair in pairs.items():
        values[name], per_round[name] = (None, None) if pair is None else paired(*pair)
        if name in why:
            values[name + REASON] = why[name]
    by_count = {n: {k: paired(*p) for k, p in r.items()} for n, r in by_samples.items()}
    return {
        "ratios": values,
        "ratios_rounds": per_round,
        "ratios_by_samples": {n: {k: v[0] for k, v in r.items()} for n, r in by_count.items()},
        "ratios_by_samples_rounds": {n: {k: v[1] for k, v in r.items()} for n, r in by_count.items()},
        "reasons": why,
    }


def machine(ctx: moderngl.Context) -> dict:
    info = ctx.info
    cpu_model = None
    try:
        with open("/proc/cpuinfo") as cpuinfo:  # Linux only; None elsewhere
            models = [line.split(":", 1)[1].strip() for line in cpuinfo if line.startswith("model name")]
        cpu_model = models[0] if models else None
    except OSError:
        pass
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {
        "gl_renderer": info["GL_RENDERER"],
        "gl_vendor": info["GL_VENDOR"],
        "gl_version": info["GL_VERSION"],
        "cpu_count": os.cpu_count(),
        "cpus_usable": usable,
        "cpu_model": cpu_model,
        "lp_num_threads": os.environ.get("LP_NUM_THREADS"),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "numpy": np.__version__,
        "moderngl": moderngl.__version__,
    }


def format_table(figures) -> str:
    header = (
        "figure",
        "mode",
        "scene",
        "size",
        "samples",
        "scale",
        "min ms",
        "median ms",
        "max ms",
        "/ floor",
        "GTX285 ms",
        "peak MB",
    )
    rows = [header]
    for f in figures:
        rows.append(
            (
                f.name,
                f.mode or "",
                f.scene,
                f"{f.width}x{f.height}",
                str(f.samples or ""),
                "" if f.scale is None else ("full" if f.scale == 1.0 else "half"),
                f"{min(f.times_ms):.1f}",
                f"{f.median_ms:.1f}",
                f"{max(f.times_ms):.1f}",
                "" if f.over_fetch_floor is None else f"{f.over_fetch_floor:.2f}",
                "" if f.paper_ms is None else f"{f.paper_ms:.1f}",
                "" if f.peak_rss_mb is None else f"{f.peak_rss_mb:.0f}",
            )
        )
    widths = [max(len(r[i]) for r in rows) for i in range(len(header))]
    numeric = range(4, len(header))
    lines = [
        "  ".join(c.rjust(wd) if i in numeric else c.ljust(wd) for i, (c, wd) in enumerate(zip(r, widths))).rstrip()
        for r in rows
    ]
    lines.insert(1, "-" * len(lines[0]))
    return "\n".join(lines)


def spread(rounds: list | None) -> str:
    """How far the rounds of a paired ratio strayed, e.g. ``(rounds 1.18-2.24)``."""
    if not rounds:
        return ""
    if len(rounds) == 1:
        return "(1 round)"
    return f"(rounds {min(rounds):.2f}-{max(rounds):.2f})"


def format_ratios(measured: dict, run: dict) -> str:
    """The ratios against their targets, each with its per-round spread, then by sample count."""
    ratios, rounds = measured["ratios"], measured["ratios_rounds"]
    by_samples, by_samples_rounds = measured["ratios_by_samples"], measured["ratios_by_samples_rounds"]
    width = max(len(name) for name in ratios if not name.endswith(REASON))

    def shown(value, spread):
        return f"{'null' if value is None else format(value, '.3f'):>6} {spread:<21}"

    lines = [
        f"ratios (median of per-round ratios, this run; {RATIO_SAMPLES} samples, {PAPER_SIZE[0]}x{PAPER_SIZE[1]}):"
    ]
    if run["quick"]:
        rounds_run = f"{run['repeat']} round" + ("s" if run["repeat"] != 1 else "")
        lines.append(f"  --quick: verdicts from {rounds_run} are indicative; targets are judged on full runs")
    for name, value in ratios.items():
        if name.endswith(REASON):
            continue  # printed on its ratio's line
        why = ratios.get(name + REASON)
        head = f"  {name:<{width}}  {shown(value, spread(rounds.get(name)))}"
        if name in PEER_TARGETS:  # a minimum: mrcheck's frame must be that many times faster
            verdict = f"(not run: {why})" if value is None else ("meets" if value >= PEER_TARGETS[name] else "MISSES")
            lines.append(
                f"{head}  target >= {PEER_TARGETS[name]:.2f}  {verdict}  "
                f"(peer frame / mrcheck frame, {PEER_SIZE[0]}x{PEER_SIZE[1]}, {PEER_SAMPLES} samples, "
                f"blur {PEER_BLUR})"
            )
        elif name not in TARGETS:  # measured for information, no target (e.g. the peers at half-resolution AO)
            lines.append(f"{head}  (no target" + (f"; not run: {why})" if value is None else ")"))
        else:
            verdict = "meets" if value <= TARGETS[name] else "MISSES"
            if name in EVERY_SAMPLE_COUNT and len(by_samples) > 1:  # the verdict over every count
                meets = [n for n, r in by_samples.items() if r[name] <= TARGETS[name]]
                misses = [n for n in by_samples if n not in meets]
                verdict = (
                    "meets at every sample count measured"
                    if not misses
                    else "; ".join(
                        ([f"meets at {', '.join(meets)}"] if meets else []) + [f"MISSES at {', '.join(misses)}"]
                    )
                    + " samples"
                )
            lines.append(f"{head}  target <= {TARGETS[name]:.2f}  {verdict}")
    lines.append(f"by samples, sample scene at {PAPER_SIZE[0]}x{PAPER_SIZE[1]}:")
    for name in next(iter(by_samples.values()), {}):
        for n, r in by_samples.items():
            if name in EVERY_SAMPLE_COUNT or n == str(RATIO_SAMPLES):
                verdict = "meets" if r[name] <= TARGETS[name] else "MISSES"
            else:
                verdict = f"(target at {RATIO_SAMPLES} only)"
            lines.append(
                f"  {name:<{width}}  {n:>3}  {shown(r[name], spread(by_samples_rounds[n][name]))}"
                f"  target <= {TARGETS[name]:.2f}  {verdict}"
            )
    return "\n".join(line.rstrip() for line in lines)


def report_text(report: dict, figures: list[Figure]) -> str:
    """What ``mrcheck bench`` prints: the table of figures, the ratios, the machine and the notes."""
    machine = report["machine"]
    lines = [format_table(figures), "", format_ratios(report, report["run"]), ""]
    lines.append(
        f"machine: {machine['gl_renderer']}, {machine['cpus_usable']} of {machine['cpu_count']} CPUs usable, "
        f"Python {machine['python']}; {report['run']['repeat']} timed runs per figure after 1 warm-up; "
        f"peak RSS {report['peak_rss_mb']:.0f} MB over the whole run"
    )
    for f in figures:
        if f.name == "frame" and "png" in f.stats:  # the frames the peer ratios compare, to look at
            lines.append(f"frame {f.mode}: {f.stats['png']}" + (f" ({f.stats['peer']})" if "peer" in f.stats else ""))
    for scene, triangles in {f.scene: f.triangles for f in figures if f.name == "frame" and f.triangles}.items():
        lines.append(
            f"{scene}: the line scene the project ships, {triangles:,} triangles (the issue names a 1 M-triangle "
            "line scene)"
        )
    lines.append(
        "/ floor: an AO pass over the fetch floor of its size, samples and resolution (same depth fetches, "
        "trivial arithmetic), timed in turns with it."
    )
    lines.append(f"peak MB: {report['peak_rss_per_figure']}.")
    lines.append(
        "GTX285 ms: Scheer & Keutel's own method (vector) on a GTX 285 at 1280x1024, Table 1 (AO pass) and "
        "Table 2 (blur; whole frame at 16 samples with 13x13, 36 with 9x9), on their scene, for comparison."
    )
    return "\n".join(lines)


__all__ = [
    "find",
    "per_round_ratios",
    "paired",
    "ratio",
    "floor_ratios",
    "ratios",
    "machine",
    "format_table",
    "spread",
    "format_ratios",
    "report_text",
]
