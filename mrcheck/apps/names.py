"""The names of the files ``mrcheck export`` and ``mrcheck review`` write and read: one place.

An export folder::

    OUTDIR/manifest.json, OUTDIR/report.html
    OUTDIR/shots/NAME/SHOT.json, record.json, sheet.png,
                      render_phong.png, render_MODE_iI.png, overlay_phong_aA.png, overlay_MODE_iI_aA.png

(numbers as ``{x:g}``: ``i1``, ``i0.5``, ``a0``). The review keeps ``review.sqlite`` and its render
cache ``.review-cache/`` in the reviewed folder, with ``--self-signed`` its certificates in
``review-tls/`` beside them, the camera its "Calibrate" solved in ``review-camera/camera.json``,
and names the downloads of its report and CSV ``review.html`` and ``review.csv``.
"""

from __future__ import annotations

import re
from pathlib import Path

from mrcheck.render.renderer import MODES

MANIFEST = "manifest.json"  # the job's, in OUTDIR
REPORT = "report.html"  # the export's, in OUTDIR
SHOTS = "shots"  # OUTDIR/shots/NAME/: one folder per shot
SHOT_FILE = "SHOT.json"  # a shot folder's registered shot
RECORD = "record.json"  # a shot folder's record, written last: the shot is finished
SHEET = "sheet.png"  # a shot folder's study sheet

REVIEW_DATABASE = "review.sqlite"  # the review's markers, in the reviewed folder (or --db)
REVIEW_CACHE = ".review-cache"  # the review's render cache, beside its database
REVIEW_TLS = "review-tls"  # --self-signed: the review's certificates, beside its database
TLS_CA = "ca.pem"  # in REVIEW_TLS: the certificate a tablet trusts, which signed TLS_CERT
TLS_CERT = "cert.pem"  # in REVIEW_TLS: the server's certificate
TLS_KEY = "key.pem"  # in REVIEW_TLS: its private key (mode 0600)
REVIEW_CAMERA = "review-camera"  # the camera "Calibrate" solved in the review, beside its database
LIVE_CAMERA = "camera.json"  # in REVIEW_CAMERA: Live's intrinsics (intrinsics only, no pose)
REVIEW_REPORT = "review.html"  # the review's HTML report, as downloaded
REVIEW_CSV = "review.csv"  # the review's markers, as downloaded

_AO = "|".join(m for m in MODES if m != "phong")
_NUM = r"[0-9][0-9.e+-]*"  # a number as number() writes it: 1, 0.5, 1e-05
# every name the export writes into a shot folder (temp files included): only these are ever removed
_EXPORT_NAME = re.compile(
    rf"(render_phong|render_({_AO})_i{_NUM}|overlay_phong_a{_NUM}|overlay_({_AO})_i{_NUM}_a{_NUM}"
    rf"|sheet)\.png|SHOT\.json|record\.json|\..+\.part"
)
_SHOT_NAME = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9._-]*")


def number(x: float) -> str:
    """A number in a file name: ``1``, ``0.5``, ``1e-05``."""
    return f"{x:g}"


def view_tag(mode: str, intensity: float | None) -> str:
    """``phong`` or ``MODE_iI``: a mode at an AO intensity (phong has none)."""
    return "phong" if mode == "phong" else f"{mode}_i{number(intensity)}"


def render_name(mode: str, intensity: float | None) -> str:
    """The CAD alone: ``render_phong.png``, ``render_MODE_iI.png``."""
    return f"render_{view_tag(mode, intensity)}.png"


def overlay_name(mode: str, intensity: float | None, alpha: float) -> str:
    """The CAD over the photo at opacity ``alpha``: ``overlay_phong_aA.png``, ``overlay_MODE_iI_aA.png``."""
    return f"overlay_{view_tag(mode, intensity)}_a{number(alpha)}.png"


def is_export_name(name: str) -> bool:
    """Whether ``name`` is one the export writes into a shot folder (its temp files included):
    the only files the export ever removes."""
    return bool(_EXPORT_NAME.fullmatch(name))


def is_shot_name(name: str) -> bool:
    """A usable shot name: letters, digits, ``.``, ``_`` and ``-``, not starting with a dot."""
    return bool(_SHOT_NAME.fullmatch(name))


def shot_name(stem: str) -> str:
    """The shot name of a file's stem (a photo of a glob, a SHOT.json): sanitised, never empty."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", stem).lstrip(".") or "shot"


def shot_folder(outdir, name: str) -> Path:
    """``OUTDIR/shots/NAME``."""
    return Path(outdir) / SHOTS / name


def cached_name(kind: str, tag: str, width: int, stamp: str) -> str:
    """A file of the review's render cache: ``KIND[_TAG]_wWIDTH_STAMP.png`` (KIND photo, thumb,
    edges or render; the tag of a render is its :func:`view_tag`)."""
    return f"{kind}{'_' + tag if tag else ''}_w{width}{cached_suffix(stamp)}"


def cached_suffix(stamp: str) -> str:
    """How every :func:`cached_name` of ``stamp`` ends."""
    return f"_{stamp}.png"


CACHED_PREFIXES = ("photo_", "thumb_", "edges_", "render_")  # the cache's own file names (cached_name)
