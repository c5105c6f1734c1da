"""The report of ``regress check``: ``report.html`` (baseline / now / difference side by side
per view and mode, a summary table, the elements under the changed pixels), ``junit.xml`` (one
test case per view, for CI) and the images beside them (``images/``)."""

from __future__ import annotations

import datetime
import xml.etree.ElementTree as ET
from pathlib import Path

from mrcheck.apps.regress.attribution import element_label
from mrcheck.apps.regress.compare import Tolerances, difference_image
from mrcheck.apps.templating import render
from mrcheck.core.output import write_bytes, write_image, write_text

IMAGES = "images"
SHOWN_ELEMENTS = 50  # elements listed per view in the HTML (the rest counted)


def picture_names(view: str, mode: str) -> dict[str, str]:
    return {k: f"{IMAGES}/{view}_{mode}_{k}.png" for k in ("baseline", "now", "diff")}


def report_writes(outdir: Path, result, pictures: dict, tolerances: Tolerances) -> list:
    """The writes (callables) of the whole report: images, then junit.xml, then report.html.
    ``result``: the :class:`~mrcheck.apps.regress.run.CheckResult`; ``pictures``: view ->
    (baseline images, new images) by mode."""
    writes = []
    for view in result.views:
        before, now = pictures[view.name]
        for comparison in view.modes:
            names = picture_names(view.name, comparison.mode)
            writes += [
                lambda p=outdir / names["baseline"], im=before[comparison.mode]: write_image(p, im),
                lambda p=outdir / names["now"], im=now[comparison.mode]: write_image(p, im),
                lambda p=outdir / names["diff"], c=comparison: write_image(p, difference_image(c.error, c.changed)),
            ]
    writes.append(lambda: write_bytes(outdir / "junit.xml", junit_xml(result)))
    writes.append(lambda: write_text(outdir / "report.html", report_html(result, tolerances)))
    return writes


def junit_xml(result) -> bytes:
    """One ``testcase`` per view (classname: the scene's name), a ``failure`` naming the modes
    over tolerance and the elements under the changed pixels."""
    scene = (
        Path(result.baseline.scene).parent.name if result.baseline.scene.endswith(".toml") else result.baseline.scene
    )
    suite = ET.Element(
        "testsuite",
        name="mrcheck regress check",
        tests=str(len(result.views)),
        failures=str(len(result.changed)),
        errors="0",
        timestamp=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
    )
    for view in result.views:
        case = ET.SubElement(suite, "testcase", classname=f"mrcheck.regress.{Path(scene).name}", name=view.name)
        if not view.passed:
            why = view.reasons()
            names = ", ".join(element_label(e) for e in view.elements) or "no element (background)"
            failure = ET.SubElement(case, "failure", message=f"view {view.name} changed: {why}")
            failure.text = f"elements under the changed pixels: {names}\nsee {picture_names(view.name, 'MODE')['diff']}"
    ET.indent(suite)
    return ET.tostring(ET.ElementTree(suite).getroot(), encoding="utf-8", xml_declaration=True) + b"\n"


def report_html(result, tolerances: Tolerances) -> str:
    views = [
        {
            "name": v.name,
            "passed": v.passed,
            "modes": [
                {
                    "mode": m.mode,
                    "mean": f"{m.mean:.4f}",
                    "high": f"{m.high:.3f}",
                    "changed": m.changed_pixels,
                    "passed": m.passed,
                    "reason": m.reason,
                    "pictures": picture_names(v.name, m.mode),
                }
                for m in v.modes
            ],
            "elements": [
                {
                    "label": element_label(e),
                    "part": e.part,
                    "instance": e.instance,
                    "name": e.name,
                    "ifc_class": e.ifc_class,
                    "pixels": e.pixels,
                    "kind": e.kind,
                }
                for e in v.elements[:SHOWN_ELEMENTS]
            ],
            "more": max(0, len(v.elements) - SHOWN_ELEMENTS),
            "geometry": {"pixels": v.geometry_pixels, "limit": v.geometry_limit, "passed": v.geometry_passed},
        }
        for v in result.views
    ]
    b = result.baseline
    return render(
        "mrcheck.apps.regress",
        "report.html.j2",
        passed=result.passed,
        changed=len(result.changed),
        views=views,
        baseline=b,
        scene=result.scene,
        gl_renderer=result.gl_renderer,
        scene_changed=result.scene_stamp != b.scene_stamp,
        tolerances=tolerances,
        max_pixels=round(tolerances.max_changed * b.width * b.height),
    )


def index_html(results, root: Path) -> str:
    """The pytest plugin's summary: each snapshot's key, verdict and a link to its report."""
    rows, root = [], root.resolve()
    for key, passed, report in results:
        report = Path(report).resolve()
        href = report.relative_to(root).as_posix() if report.is_relative_to(root) else report.as_uri()
        rows.append({"key": key, "passed": passed, "href": href})
    return render("mrcheck.apps.regress", "index.html.j2", rows=rows, failed=sum(not r["passed"] for r in rows))


__all__ = ["report_writes", "junit_xml", "report_html", "picture_names", "index_html"]
