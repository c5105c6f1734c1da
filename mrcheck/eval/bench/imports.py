"""Import figures of ``mrcheck bench``: the IFC importer on one core and on both, the cached
reload, STEP tessellation time per MB.

Timings on a shared machine are noisy: the one- and two-thread imports run interleaved
(1, 2, 1, 2, ...) in one process and each figure is the fastest of its rounds, with every
round's ratio kept, so that a load spike during one run does not decide the speed-up. The
caller supplies the files (the generated hall written as IFC, the STEP test models), and each
figure carries the load average it was measured at.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path

from mrcheck.scene.importers import ImportSettings, read_model

TWO_CORE_TARGET = 1.7  # the target: two cores import at least 1.7x as fast as one


@dataclass
class IfcFigures:
    """The IFC importer on one file: fastest seconds per thread count, and every round."""

    file: str
    megabytes: float
    elements: int
    triangles: int
    seconds: dict  # {threads: fastest seconds}
    rounds: dict  # {threads: [seconds of every round]}
    load: tuple  # os.getloadavg() before the first round

    def elements_per_s(self, threads: int) -> float:
        return self.elements / self.seconds[threads]

    def mb_per_s(self, threads: int) -> float:
        return self.megabytes / self.seconds[threads]

    @property
    def speedup(self) -> float | None:
        return self.seconds[1] / self.seconds[2] if 1 in self.seconds and 2 in self.seconds else None

    @property
    def round_speedups(self) -> list:
        return [a / b for a, b in zip(self.rounds.get(1, []), self.rounds.get(2, []))]


@dataclass
class CacheFigures:
    """First load (import, write the cache, read the scene) against the second (hash, read)."""

    first_s: float
    reload_s: float
    load: tuple

    @property
    def share(self) -> float:
        return self.reload_s / self.first_s


@dataclass
class StepFigures:
    """STEP read + tessellation per file."""

    files: list = field(default_factory=list)  # (name, megabytes, seconds, triangles)
    load: tuple = ()

    @property
    def seconds_per_mb(self) -> float:
        total_mb = sum(f[1] for f in self.files)
        return sum(f[2] for f in self.files) / total_mb if total_mb else float("nan")


def _load() -> tuple:
    return tuple(round(v, 2) for v in os.getloadavg())


def measure_ifc(path: Path, rounds: int = 2, threads=(1, 2)) -> IfcFigures:
    """Import ``path`` ``rounds`` times at each thread count, interleaved."""
    times = {n: [] for n in threads}
    load = _load()
    model = None
    for _ in range(rounds):
        for n in threads:
            start = time.perf_counter()
            model = read_model(path, ImportSettings(threads=n))
            times[n].append(time.perf_counter() - start)
    return IfcFigures(
        file=Path(path).name,
        megabytes=os.path.getsize(path) / 1e6,
        elements=model.element_count,
        triangles=model.triangle_count,
        seconds={n: min(t) for n, t in times.items()},
        rounds=times,
        load=load,
    )


def measure_cache(path: Path, cache_dir: Path) -> CacheFigures:
    """The first and the second load of ``path`` through a fresh cache in ``cache_dir``."""
    from mrcheck.scene.model import load_scene

    saved = os.environ.get("MRCHECK_CACHE_DIR")
    os.environ["MRCHECK_CACHE_DIR"] = str(cache_dir)
    load = _load()
    try:
        start = time.perf_counter()
        load_scene(path)
        first = time.perf_counter() - start
        start = time.perf_counter()
        load_scene(path)
        reload = time.perf_counter() - start
    finally:
        if saved is None:
            os.environ.pop("MRCHECK_CACHE_DIR", None)
        else:
            os.environ["MRCHECK_CACHE_DIR"] = saved
    return CacheFigures(first_s=first, reload_s=reload, load=load)


def measure_step(paths) -> StepFigures:
    """Read and tessellate every STEP file (default tolerance) once after a warm-up read (the
    first pays for loading OpenCascade's libraries)."""
    paths = [Path(p) for p in paths]
    figures = StepFigures(load=_load())
    if paths:
        read_model(paths[0])
    for path in paths:
        start = time.perf_counter()
        model = read_model(path)
        figures.files.append(
            (path.name, os.path.getsize(path) / 1e6, time.perf_counter() - start, model.triangle_count)
        )
    return figures


def format_imports(ifc: IfcFigures | None, cache: CacheFigures | None, step: StepFigures | None) -> list[str]:
    """The report's lines (what was measured, at which load)."""
    lines = []
    if ifc is not None:
        for n in sorted(ifc.seconds):
            lines.append(
                f"IFC import {ifc.file} ({ifc.megabytes:.1f} MB, {ifc.elements:,} elements, "
                f"{ifc.triangles:,} triangles), {n} thread(s): {ifc.seconds[n]:.2f} s = "
                f"{ifc.elements_per_s(n):,.0f} elements/s, {ifc.mb_per_s(n):.2f} MB/s"
            )
        if ifc.speedup is not None:
            verdict = "meets" if ifc.speedup >= TWO_CORE_TARGET else "MISSES"
            rounds = ", ".join(f"{s:.2f}" for s in ifc.round_speedups)
            lines.append(
                f"IFC import two threads / one: {ifc.speedup:.2f}x (rounds {rounds}); {verdict} the "
                f"{TWO_CORE_TARGET}x target (load {ifc.load[0]:.1f})"
            )
    if cache is not None:
        lines.append(
            f"IFC first load {cache.first_s:.2f} s, cached reload {cache.reload_s:.2f} s "
            f"({100 * cache.share:.0f} % of the first; load {cache.load[0]:.1f})"
        )
    if step is not None and step.files:
        total = sum(f[1] for f in step.files)
        lines.append(
            f"STEP read + tessellation: {step.seconds_per_mb:.2f} s per MB over {len(step.files)} files "
            f"({total:.2f} MB; load {step.load[0]:.1f})"
        )
    return lines


@dataclass
class ImportReport:
    """The import section of a bench run: its figures, as JSON and as report lines."""

    ifc: IfcFigures | None
    cache: CacheFigures | None
    step: StepFigures | None

    def to_json(self) -> dict:
        from dataclasses import asdict

        out = {
            k: asdict(v) for k, v in (("ifc", self.ifc), ("cache", self.cache), ("step", self.step)) if v is not None
        }
        if self.ifc is not None:
            out["ifc"].update(
                speedup=self.ifc.speedup,
                round_speedups=self.ifc.round_speedups,
                target_speedup=TWO_CORE_TARGET,
                elements_per_s={n: self.ifc.elements_per_s(n) for n in self.ifc.seconds},
                mb_per_s={n: self.ifc.mb_per_s(n) for n in self.ifc.seconds},
            )
        if self.cache is not None:
            out["cache"]["share"] = self.cache.share
        if self.step is not None:
            out["step"]["seconds_per_mb"] = self.step.seconds_per_mb
        return out

    def lines(self) -> list[str]:
        return format_imports(self.ifc, self.cache, self.step)


def measure_imports(hall_ifc: Path | None, step_files, workdir: Path, rounds: int) -> ImportReport:
    """Every import figure: the IFC importer on ``hall_ifc`` (one and two threads, ``rounds``
    interleaved rounds), its first load and cached reload (a fresh cache in ``workdir``), and
    the STEP files."""
    ifc = measure_ifc(hall_ifc, rounds=rounds) if hall_ifc is not None else None
    cache = measure_cache(hall_ifc, Path(workdir) / "import-cache") if hall_ifc is not None else None
    step = measure_step(step_files) if step_files else None
    return ImportReport(ifc, cache, step)


__all__ = [
    "ImportReport",
    "measure_imports",
    "IfcFigures",
    "CacheFigures",
    "StepFigures",
    "measure_ifc",
    "measure_cache",
    "measure_step",
    "format_imports",
    "TWO_CORE_TARGET",
]
