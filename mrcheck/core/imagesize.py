"""An image's size read from its header, before anything is decoded: a PNG of 30000 x 30000 px
is some 100 kB on disk and 2.7 GB decoded, so a program that takes images from others checks
the pixel count first (:func:`mrcheck.core.images.decode_image`'s ``max_pixels``).

Read here (the standard library only): PNG (IHDR), JPEG (the first SOFn frame header; the
EXIF thumbnail inside APP1 is skipped with its segment), TIFF (the first IFD, the page OpenCV
decodes), BMP, GIF (the logical screen) and WebP (VP8, VP8L, VP8X). Any other format's size
is unknown here (None): a caller with a pixel limit refuses it.
"""

from __future__ import annotations

import struct

READABLE = "PNG, JPEG, TIFF, BMP, GIF, WebP"
# JPEG frame headers: SOF0..SOF15 without DHT (C4), JPG (C8) and DAC (CC)
_SOF = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}
_NO_LENGTH = frozenset(range(0xD0, 0xD8)) | {0x01, 0xD8}  # RSTn, TEM, SOI: markers without a segment
_MAX_SEGMENTS = 4096  # a JPEG has a few dozen segments before its frame header


class HeaderError(ValueError):
    """A header that ends early or contradicts itself."""


def _unpack(fmt: str, data: bytes, offset: int) -> tuple:
    if len(data) < offset + struct.calcsize(fmt):
        raise HeaderError("truncated header")
    return struct.unpack_from(fmt, data, offset)


def _png(data: bytes) -> tuple[int, int]:
    if data[12:16] != b"IHDR":
        raise HeaderError("no IHDR chunk first")
    return _unpack(">II", data, 16)


def _jpeg(data: bytes) -> tuple[int, int]:
    pos = 2
    for _ in range(_MAX_SEGMENTS):
        while pos < len(data) and data[pos] == 0xFF:  # fill bytes before a marker
            pos += 1
        if pos >= len(data):
            break
        marker, pos = data[pos], pos + 1
        if marker in _NO_LENGTH:
            continue
        if marker in (0xD9, 0xDA):  # EOI, SOS: the image data, before any frame header
            raise HeaderError("no frame header before the image data")
        (length,) = _unpack(">H", data, pos)
        if marker in _SOF:
            height, width = _unpack(">HH", data, pos + 3)
            if height == 0:  # the height is given later, by a DNL segment after the first scan
                raise HeaderError("a frame without its height (DNL)")
            return width, height
        if length < 2:
            raise HeaderError("a segment of impossible length")
        pos += length
    raise HeaderError("no frame header")


def _tiff(data: bytes) -> tuple[int, int]:
    order = "<" if data[:2] == b"II" else ">"
    (ifd,) = _unpack(order + "I", data, 4)
    (count,) = _unpack(order + "H", data, ifd)
    size = {}
    for k in range(count):
        tag, kind = _unpack(order + "HH", data, ifd + 2 + 12 * k)
        if tag in (256, 257):  # ImageWidth, ImageLength: SHORT (3) or LONG (4), left-justified in the value
            (size[tag],) = _unpack(order + ("H" if kind == 3 else "I"), data, ifd + 2 + 12 * k + 8)
    if len(size) < 2:
        raise HeaderError("no image width and length in the first directory")
    return size[256], size[257]


def _bmp(data: bytes) -> tuple[int, int]:
    (header,) = _unpack("<I", data, 14)
    if header == 12:  # OS/2 BITMAPCOREHEADER: 16-bit sizes
        return _unpack("<HH", data, 18)
    width, height = _unpack("<ii", data, 18)
    return abs(width), abs(height)  # a negative height: rows top-down


def _webp(data: bytes) -> tuple[int, int]:
    chunk = data[12:16]
    if chunk == b"VP8 ":
        width, height = _unpack("<HH", data, 26)
        return width & 0x3FFF, height & 0x3FFF
    if chunk == b"VP8L":
        b0, b1, b2, b3 = _unpack("<BBBB", data, 21)
        return 1 + (b0 | (b1 & 0x3F) << 8), 1 + (b1 >> 6 | b2 << 2 | (b3 & 0x0F) << 10)
    if chunk == b"VP8X":
        w0, w1, w2, h0, h1, h2 = _unpack("<BBBBBB", data, 24)
        return 1 + (w0 | w1 << 8 | w2 << 16), 1 + (h0 | h1 << 8 | h2 << 16)
    raise HeaderError(f"unknown WebP chunk {chunk!r}")


_READERS = {
    "PNG": _png,
    "JPEG": _jpeg,
    "TIFF": _tiff,
    "BMP": _bmp,
    "GIF": lambda data: _unpack("<HH", data, 6),
    "WebP": _webp,
}


def image_size(data: bytes, kind: str | None) -> tuple[int, int] | None:
    """(width, height) from the header of the encoded image ``data`` of format ``kind`` (as
    :func:`mrcheck.core.images.image_format` names it); None for a format not read here;
    :class:`HeaderError` for a header that ends early or makes no sense."""
    reader = _READERS.get(kind or "")
    return None if reader is None else tuple(reader(data))


__all__ = ["image_size", "HeaderError", "READABLE"]
