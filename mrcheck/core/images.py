"""Image files in and out: :func:`read_image` reads every image mrcheck reads (photos, calibration
views, the review's cached renders, the export's sheets), :func:`encode_image` encodes every
image it writes (through :func:`mrcheck.core.output.write_image`, atomically, or served as bytes).

OpenCV decodes from and encodes to memory here, never from or to a file name: ``cv2.imread``,
``cv2.imwrite`` (and ``cv2.FileStorage``) hand the name to C++ as UTF-8 and crash the process
(SIGSEGV, exit 139) on a name that is not valid UTF-8, such as ``Halle_S\\xfcd.png`` from a
Latin-1 camera or file share. Python's file API takes any name the file system does.

A file that does not decode is one line naming it and the real problem: empty, a text file, a
format OpenCV does not read (HEIC), truncated, or corrupt with the codec's own reason. The
codecs' messages (OpenCV's ``[ WARN``/``[ERROR`` lines, libpng's, libjpeg's) never reach the
terminal (:func:`mrcheck.core.quiet.native_output`); of an image that decodes they are dropped (a
phone JPEG with "extraneous bytes before marker 0xd9" is a good photo).

A photo from someone else is bounded before it is decoded: a PNG of 30000 x 30000 px is some
100 kB on disk and 2.7 GB decoded, so its size is read from its header first (Pillow's readers,
:func:`check_pixels`) and a photo over ``--max-pixels`` (:func:`max_pixels`) is refused.
"""

from __future__ import annotations

import io
import re
import struct
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
from PIL import (
    AvifImagePlugin,
    BmpImagePlugin,
    GifImagePlugin,
    Image,
    ImageFile,
    Jpeg2KImagePlugin,
    JpegImagePlugin,
    PngImagePlugin,
    PpmImagePlugin,
    SunImagePlugin,
    TiffImagePlugin,
    WebPImagePlugin,
)

from mrcheck.core.errors import MrcheckError
from mrcheck.core.inputs import read_input
from mrcheck.core.quiet import native_output

# the leading bytes of the formats OpenCV reads (and of HEIC, which it does not), to say what a
# file that does not decode was meant to be; the decoder itself decides what decodes
_SIGNATURES = (
    (b"\x89PNG\r\n\x1a\n", "PNG"),
    (b"\xff\xd8\xff", "JPEG"),
    (b"II*\x00", "TIFF"),
    (b"MM\x00*", "TIFF"),
    (b"BM", "BMP"),
    (b"GIF87a", "GIF"),
    (b"GIF89a", "GIF"),
    (b"\x00\x00\x00\x0cjP  \r\n\x87\n", "JPEG 2000"),
    (b"\xff\x4f\xff\x51", "JPEG 2000"),
    (b"#?RADIANCE", "HDR"),
    (b"#?RGBE", "HDR"),
    (b"\x59\xa6\x6a\x95", "Sun raster"),
)
_HEIC_BRANDS = {b"heic", b"heix", b"hevc", b"hevx", b"heim", b"heis", b"msf1"}
_PNG_END = b"IEND\xaeB`\x82"  # the IEND chunk (type and CRC) every complete PNG ends with
_JPEG_END = b"\xff\xd9"  # EOI; cameras may append a few bytes after it
# "[ WARN:0@0.050] global grfmt_png.cpp:793 readFromStreamOrBuffer " before OpenCV's own words
_OPENCV_PREFIX = re.compile(r"^\[\s*[A-Z]+:[^\]]*\]\s*(global\s+\S+\s+\S+\s+)?")
SUPPORTED = "PNG, JPEG, TIFF, BMP, WebP, AVIF, JPEG 2000, GIF, PNM"
# Pillow's reader of each format above whose size is read from its header (constructing one reads
# the header, decodes nothing). Its classes, not ``PIL.Image.open``: open() also applies Pillow's
# own decompression-bomb limit, which warns above 89 MP and refuses above 179 MP without saying
# the size, whatever --max-pixels allows.
_HEADER_READERS: dict[str, Callable[[io.BytesIO], ImageFile.ImageFile]] = {
    "PNG": PngImagePlugin.PngImageFile,
    "JPEG": JpegImagePlugin.JpegImageFile,
    "TIFF": TiffImagePlugin.TiffImageFile,
    "BMP": BmpImagePlugin.BmpImageFile,
    "GIF": GifImagePlugin.GifImageFile,
    "WebP": WebPImagePlugin.WebPImageFile,
    "AVIF": AvifImagePlugin.AvifImageFile,
    "JPEG 2000": Jpeg2KImagePlugin.Jpeg2KImageFile,
    "PNM": PpmImagePlugin.PpmImageFile,
    "Sun raster": SunImagePlugin.SunImageFile,
}
READABLE = ", ".join(_HEADER_READERS)
# the largest photo read, checked on its header before decoding: 64 MP takes the 61 MP of the
# largest full-frame sensors and a phone's 48/50 MP mode; decoded, that is 192 MB of RGB, and
# edge snapping makes float copies of it (4 bytes a pixel each). ``mrcheck --max-pixels`` sets it
# for every command (:func:`set_max_pixels`), ``review --max-pixels`` for the review.
MAX_PIXELS = 64_000_000
_PIXELS = re.compile(r"(?P<number>[0-9]+(?:\.[0-9]+)?)\s*(?P<mega>m(?:p|px)?)?")
_limit = {"max_pixels": MAX_PIXELS}


def parse_pixels(text: str) -> int:
    """Pixels of a count such as ``64MP``, ``50M``, ``0.5MP`` or ``12000000`` (M: a million);
    ValueError saying what is wrong."""
    match = _PIXELS.fullmatch(str(text).strip().lower())
    pixels = 0 if match is None else int(float(match["number"]) * (1_000_000 if match["mega"] else 1))
    if pixels < 1:
        raise ValueError(f"{text!r} is not a pixel count (e.g. 64MP, 50M or 12000000)")
    return pixels


def set_max_pixels(pixels: int) -> None:
    """The limit of :func:`max_pixels` for this process (``mrcheck --max-pixels``)."""
    _limit["max_pixels"] = int(pixels)


def max_pixels() -> int:
    """The largest photo, in pixels, that the commands read (:data:`MAX_PIXELS` unless set)."""
    return _limit["max_pixels"]


def image_format(data: bytes) -> str | None:
    """The image format ``data`` starts like ("PNG", "JPEG", "HEIC" ...), or None."""
    for signature, name in _SIGNATURES:
        if data.startswith(signature):
            return name
    if data[:4] == b"RIFF" and data[8:12] == b"WEBP":
        return "WebP"
    if data[4:8] == b"ftyp":
        brand = data[8:12]
        return "HEIC" if brand in _HEIC_BRANDS else "AVIF" if brand in (b"avif", b"avis") else None
    if len(data) > 2 and data[0:1] == b"P" and data[1:2] in b"123456" and data[2:3].isspace():
        return "PNM"
    return None


def _is_text(data: bytes) -> bool:
    """The start of ``data`` is UTF-8 text without control characters other than white space."""
    head = data[:4096]
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError as exc:
        if exc.start < len(head) - 3:  # not only a character cut at the 4096-byte mark
            return False
        text = head[: exc.start].decode("utf-8")
    return all(c.isprintable() or c in "\t\n\r\f" for c in text)


def _decode_problem(data: bytes, log: list) -> str:
    """Why ``data`` did not decode, in a planner's words."""
    kind = image_format(data)
    if kind != "PNM" and _is_text(data):  # an ASCII PNM is text, and an image
        return "a text file, not an image"
    if kind is None:
        return f"not an image in a format OpenCV reads ({SUPPORTED})"
    if kind == "HEIC":
        return "a HEIC image, which OpenCV does not read: export it as JPEG or PNG"
    if (kind == "PNG" and not data.rstrip(b"\x00").endswith(_PNG_END)) or (
        kind == "JPEG" and _JPEG_END not in data[-64:]
    ):
        return f"truncated {kind} (the file ends before the image does: an interrupted copy or download?)"
    reason = _OPENCV_PREFIX.sub("", next((line for line in reversed(log) if line), ""))
    return f"corrupt or truncated {kind}" + (f" ({' '.join(reason.split())[:160]})" if reason else "")


def check_size(width: int, height: int, limit: int, source=None, what: str = "photo") -> None:
    """MrcheckError naming ``source`` and its pixel count when ``width`` x ``height`` is over
    ``limit`` pixels (``--max-pixels``): a photo, or a video's frame."""
    if width * height > limit:
        raise MrcheckError(
            f"{what} is {width}x{height} px ({width * height / 1e6:.1f} MP), over the limit of {limit / 1e6:g} MP"
            " (--max-pixels)",
            source,
        )


def check_pixels(data: bytes, max_pixels: int, source=None, what: str = "image") -> tuple[int, int]:
    """(width, height) of the encoded image ``data`` from its header (Pillow's reader of its
    format), or MrcheckError when it has more than ``max_pixels`` pixels (``--max-pixels``), when
    its format's header is not read here, or when that header is broken: nothing is decoded."""
    kind = image_format(data)
    reader = _HEADER_READERS.get(kind or "")
    if reader is None:  # unknown here: only its decoding would tell its size
        problem = (
            "a text file, not an image"
            if kind is None and _is_text(data)
            else f"{f'a {kind} image' if kind else 'not an image'}: only {READABLE} are taken, "
            "whose size is checked before decoding"
        )
        raise MrcheckError(f"cannot read {what}: {problem}", source)
    try:
        with reader(io.BytesIO(data)) as header:
            w, h = header.size
    except Image.DecompressionBombError as exc:
        # the WebP and GIF readers refuse above Pillow's own limit (179 MP) before saying the size
        count = re.search(r"\((\d+) pixels\)", str(exc))
        pixels = int(count[1]) if count else 2 * (Image.MAX_IMAGE_PIXELS or 0)
        limit = f"the limit of {max_pixels / 1e6:g} MP (--max-pixels)" if max_pixels < pixels else "what Pillow reads"
        raise MrcheckError(f"{what} is {pixels / 1e6:.1f} MP, over {limit}", source) from None
    except (SyntaxError, OSError, ValueError, IndexError, TypeError, struct.error, EOFError) as exc:
        # in the words a failed decode would use: a cut-off file is "truncated", whichever reads it
        raise MrcheckError(f"cannot read {what}: {_decode_problem(data, [f'header broken: {exc}'])}", source) from None
    check_size(w, h, max_pixels, source, what)
    return w, h


def decode_image(
    data: bytes, source=None, what: str = "image", grey: bool = False, max_pixels: int | None = None
) -> np.ndarray:
    """(H, W, 3) uint8 RGB (``grey``: (H, W) uint8) of the encoded image ``data`` (EXIF
    orientation applied, as ``cv2.imread`` does), or MrcheckError "cannot read {what}: ..."
    naming ``source``. With ``max_pixels``, the header is checked first (:func:`check_pixels`)."""
    if not data:
        raise MrcheckError(f"{what} is empty (0 bytes)", source)
    if max_pixels is not None:
        check_pixels(data, max_pixels, source, what)
    flags = cv2.IMREAD_GRAYSCALE if grey else cv2.IMREAD_COLOR
    log_error: str | None
    with native_output() as log:
        try:
            image = cv2.imdecode(np.frombuffer(data, np.uint8), flags)
        except cv2.error as exc:
            image, log_error = None, exc.err
        else:
            log_error = None
    if image is None:
        raise MrcheckError(f"cannot read {what}: {_decode_problem(data, log + [log_error or ''])}", source)
    # cvtColor, not image[..., ::-1] copied: the same pixels, 1 ms instead of 230 for 12 MP
    return image if grey else cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


def read_image(path, what: str = "image", grey: bool = False, max_pixels: int | None = None) -> np.ndarray:
    """(H, W, 3) uint8 RGB (``grey``: (H, W) uint8) of an image file; every problem with the
    path (:func:`mrcheck.core.inputs.read_input`) or the content is MrcheckError naming ``path``;
    ``max_pixels``: see :func:`decode_image`."""
    return decode_image(read_input(path, what), path, what, grey, max_pixels)


def encode_image(name, image: np.ndarray, quality: int | None = None) -> bytes:
    """The file bytes of ``image`` -- (H, W, 3) uint8 RGB, (H, W, 4) RGBA, or (H, W) uint8/uint16
    grey -- in the format of ``name``'s suffix (``"x.png"``, ``".jpg"``); ``quality``: JPEG's,
    0..100. PNG carries no timestamp: the same pixels give the same bytes."""
    suffix = Path(name).suffix.lower() or str(name).lower()
    if image.ndim == 3:
        image = image[..., [2, 1, 0, 3]] if image.shape[2] == 4 else image[..., ::-1]  # OpenCV wants BGR(A)
    params = [cv2.IMWRITE_JPEG_QUALITY, int(quality)] if quality is not None else []
    try:
        ok, encoded = cv2.imencode(suffix, np.ascontiguousarray(image), params)
    except cv2.error as exc:
        raise MrcheckError(f"could not encode the image ({exc.err})", name) from None
    if not ok:
        raise MrcheckError("could not encode the image", name)
    return encoded.tobytes()


__all__ = [
    "read_image",
    "decode_image",
    "check_pixels",
    "check_size",
    "encode_image",
    "image_format",
    "SUPPORTED",
    "MAX_PIXELS",
    "max_pixels",
    "set_max_pixels",
    "parse_pixels",
]
