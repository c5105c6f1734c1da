"""Writing results: atomically (temp file + rename, never a half-written file), and the
labelled side-by-side sheet of the paper's study figure.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import cv2
import numpy as np

from mrcheck.core.errors import MrcheckError, display
from mrcheck.core.images import encode_image

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff")
AO_SUFFIXES = (".npy", ".png")


def check_output_path(path, suffixes, what="output") -> Path:
    """Validate an output path before any work is done (fail fast, not after a long render)."""
    path = Path(path)
    if path.suffix.lower() not in suffixes:
        raise MrcheckError(f"{what} must end in {', '.join(suffixes)}", path)
    if path.exists() and path.is_dir():
        raise MrcheckError(f"{what} is a directory", path)
    check_writable_ancestor(path, what)
    return path


def check_output_dir(outdir, what="output folder") -> Path:
    """OUTDIR must be a folder or not exist yet (made at write time, so bad input leaves none),
    and writable: checked before any work."""
    outdir = Path(outdir)
    if outdir.exists() and not outdir.is_dir():
        raise MrcheckError(f"{what} is a file", outdir)
    check_writable_ancestor(outdir, what, itself=True)
    return outdir


OUTPUT_MARK = ".mrcheck-output"  # in a folder mrcheck made for its results: it may write there again


def check_own_output_dir(outdir, what="output folder") -> Path:
    """:func:`check_output_dir`, and the folder is new, empty or one mrcheck made (it holds
    :data:`OUTPUT_MARK`, written by :func:`mark_output_dir`): results are never written among a
    user's files (``-o .`` in a scene's folder), nor over one of them of the same name."""
    outdir = check_output_dir(outdir, what)
    if outdir.is_dir() and not (outdir / OUTPUT_MARK).is_file() and any(outdir.iterdir()):
        raise MrcheckError(
            f"{what} holds other files and was not made by mrcheck; not writing among them "
            "(pick a new or empty folder)",
            outdir,
        )
    return outdir


def mark_output_dir(outdir) -> Path:
    """Make the output folder ``outdir`` (checked by :func:`check_own_output_dir`) and mark it as
    mrcheck's, before its results are written."""
    outdir = Path(outdir)
    if not (outdir / OUTPUT_MARK).is_file():
        write_text(outdir / OUTPUT_MARK, "Written by mrcheck: its next runs may replace the results here.\n")
    return outdir


def check_writable_ancestor(path: Path, what: str = "output", itself: bool = False) -> None:
    """Missing folders are made at write time, but one that is a file, or one that cannot be
    written (read-only, /proc), would fail only after the work: its nearest existing ancestor
    is checked now, by creating and removing a temporary file in it (permission bits say
    nothing for root or for special file systems). ``itself``: ``path`` is a folder that the
    output goes into, and counts as its own nearest ancestor."""
    path = Path(path)
    parent = next((p for p in ((path,) if itself else ()) + tuple(path.parents) if p.exists()), None)
    if parent is None:
        return
    if not parent.is_dir():
        raise MrcheckError(f"cannot write {what}: {parent} is a file, not a folder", path)
    try:
        with tempfile.TemporaryFile(dir=parent):
            pass
    except OSError as exc:
        raise MrcheckError(
            f"cannot write {what}: folder {parent} is not writable ({exc.strerror or exc})", path
        ) from None


def check_not_inputs(outputs, inputs, folders=()) -> None:
    """Refuse, before any work, an output that is one of the command's inputs: the rename of
    :func:`_atomic_write` would replace the input by the result (``register ... --points
    corr.json -o corr.json`` lost the correspondences).

    Parameters
    ----------
    outputs : paths of the files the command writes (for an output folder: each file it writes
        there, so that ``-o DIR`` is refused only when DIR/heatmap.png is the photo, say).
    inputs : ``(what, paths)`` pairs, ``what`` naming the input's role in the message
        ("--points", "the scene"); ``paths`` one path or a list of them, None for none.
    folders : folders the command replaces or empties as a whole (an as-built variant's
        ``meshes/``): an input inside one is refused too.

    The same file is the same inode (``os.path.samefile``: through a symlink, a hard link or
    another spelling of the path); an output or input that does not exist is never the same.
    """
    named: dict[tuple[int, int], tuple[str, object]] = {}  # (device, inode) -> (what, path), in the order given
    listed = []  # (what, path) of every input, for the folders
    for what, paths in inputs:
        for path in [paths] if isinstance(paths, (str, os.PathLike)) else (paths or ()):
            listed.append((what, path))
            try:
                st = os.stat(path)
            except (OSError, ValueError):  # missing: the command says so when it reads it
                continue
            named.setdefault((st.st_dev, st.st_ino), (what, path))
    for output in outputs:
        try:
            st = os.stat(output)
        except (OSError, ValueError):
            continue
        if (st.st_dev, st.st_ino) in named:
            what, path = named[st.st_dev, st.st_ino]
            raise MrcheckError(f"the output would overwrite the input {path} ({what}); write it elsewhere", output)
    for folder in folders:
        # both spellings: a link inside the folder goes with it, and so does a file reached through a link
        roots = {Path(os.path.abspath(folder)), Path(os.path.realpath(folder))}
        for what, path in listed:
            if any(
                p.is_relative_to(r) for p in (Path(os.path.abspath(path)), Path(os.path.realpath(path))) for r in roots
            ):
                raise MrcheckError(
                    f"the output would replace {folder}, which holds the input {path} ({what}); write it elsewhere",
                    folder,
                )


def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _current_umask()


def _atomic_write(path: Path, write, mode: int | None = None) -> None:
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    except OSError as exc:
        raise MrcheckError(f"cannot write output ({exc.strerror})", path) from None
    try:
        with os.fdopen(fd, "wb") as handle:
            write(handle)
        replace_output(tmp, path, mode)
    except BaseException as exc:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise MrcheckError(f"cannot write output ({exc.strerror})", path) from None
        raise


def replace_output(tmp, path, mode: int | None = None) -> Path:
    """Move the finished temporary file ``tmp`` (made with ``tempfile.mkstemp`` beside ``path``)
    into place, with the permissions a new file would get (mkstemp makes 0600: a colleague could
    not open a video or sheet written into a shared project folder), or ``mode`` (0o600: a
    private key, set before the rename, so that it is never readable by others)."""
    os.chmod(tmp, 0o666 & ~_UMASK if mode is None else mode)
    os.replace(tmp, path)
    return Path(path)


def write_bytes(path, data: bytes, mode: int | None = None) -> Path:
    """Write ``data`` to ``path`` atomically (temp file + rename); ``mode``: its permissions
    (None: a new file's, after the umask)."""
    path = Path(path)
    _atomic_write(path, lambda handle: handle.write(data), mode)
    return path


def write_text(path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (temp file + rename). A file name in it
    that is not valid UTF-8 is written as :func:`mrcheck.core.errors.display` shows it
    (``Halle_S\\xfcd.png``): the file stays valid UTF-8. JSON needs no such care: ``json.dumps``
    writes ASCII, such a name's bytes as ``\\udcNN`` escapes, which Python reads back as the
    same name."""
    return write_bytes(path, display(text).encode())


def write_image(path, image: np.ndarray) -> Path:
    """Write (H, W, 3) uint8 RGB, (H, W, 4) RGBA or (H, W) uint8/uint16 grey to PNG/JPEG/TIFF,
    atomically (:func:`mrcheck.core.images.encode_image`)."""
    return write_bytes(path, encode_image(path, image))


def write_ao(path, ao: np.ndarray) -> Path:
    """AO as ``.npy`` (float32 (H, W) in [0, 1], background 1) or 16-bit grey ``.png``."""
    path = Path(path)
    ao = np.asarray(ao, np.float32)
    if path.suffix.lower() == ".npy":
        _atomic_write(path, lambda handle: np.save(handle, ao))
    else:
        write_image(path, np.round(np.clip(ao, 0.0, 1.0) * 65535.0).astype(np.uint16))
    return path


def writer(path, content):
    """The write (a callable, for :func:`write_all_or_none`) of ``content`` to ``path``: bytes as
    they are, text as UTF-8, an array as the image format of ``path``'s suffix."""
    if isinstance(content, bytes):
        return lambda: write_bytes(path, content)
    if isinstance(content, str):
        return lambda: write_text(path, content)
    return lambda: write_image(path, content)


def write_all_or_none(writes) -> list[Path]:
    """Run ``writes`` (callables that each write one file atomically and return its path); if
    one fails, remove the files already written and re-raise. Several outputs that belong
    together (an image and its AO, a figure and its metrics) are all written or none: a part
    of them would pass for a complete result."""
    written = []
    try:
        for write in writes:
            written.append(Path(write()))
    except BaseException:
        for path in written:
            path.unlink(missing_ok=True)
        raise
    return written


_FONT = cv2.FONT_HERSHEY_SIMPLEX
_MIN_LABEL_SCALE = 0.3  # smaller is unreadable: wrap onto more lines instead


def _thickness(scale: float) -> int:
    return max(1, int(round(scale * 2)))


def _text_width(text: str, scale: float) -> int:
    return cv2.getTextSize(text, _FONT, scale, _thickness(scale))[0][0]


def _wrap(label: str, scale: float, width: int) -> list[str]:
    """``label`` broken at spaces into lines of at most ``width`` pixels at ``scale`` (a word
    longer than that stays a line of its own)."""
    lines: list[str] = []
    for word in label.split():
        if lines and _text_width(f"{lines[-1]} {word}", scale) <= width:
            lines[-1] += f" {word}"
        else:
            lines.append(word)
    return lines or [""]


def labelled_sheet(images, labels) -> np.ndarray:
    """Images side by side, each under a dark bar with its label (the study's D1 | D2 | D3).

    The label's size follows the image height; a label wider than its panel (small --width)
    is drawn smaller, and below a readable size wrapped onto more lines, rather than clipped.
    """
    h = images[0].shape[0]
    bar = max(24, h // 18)
    scale = bar / 40.0
    x = int(bar * 0.35)
    room = max(1, min(image.shape[1] for image in images) - 2 * x)  # the narrowest panel's text width
    fit = min(1.0, *(room / max(1, _text_width(label, scale)) for label in labels)) * scale
    lines, baselines = [[label] for label in labels], [int(bar * 0.72)]  # every label fits: as it always was
    if fit < scale:
        if fit >= _MIN_LABEL_SCALE:
            scale = fit
        else:
            words = [w for label in labels for w in label.split()]
            scale = max(
                0.1,
                min(
                    _MIN_LABEL_SCALE,
                    *(_MIN_LABEL_SCALE * room / max(1, _text_width(w, _MIN_LABEL_SCALE)) for w in words),
                ),
            )
            lines = [_wrap(label, scale, room) for label in labels]
        (_, text_h), base = cv2.getTextSize("Dg", _FONT, scale, _thickness(scale))
        step = text_h + base + max(2, text_h // 2)
        count = max(len(ls) for ls in lines)
        bar = max(bar, count * step + step // 2)
        top = (bar - count * step) // 2 + text_h + max(1, text_h // 4)
        baselines = [top + i * step for i in range(count)]
    thickness = _thickness(scale)
    panels = []
    for image, label_lines in zip(images, lines):
        panel = np.full((h + bar, image.shape[1], 3), 32, np.uint8)
        panel[bar:] = image
        for line, y in zip(label_lines, baselines):
            cv2.putText(panel, line, (x, y), _FONT, scale, (240, 240, 240), thickness, cv2.LINE_AA)
        panels.append(panel)
    gap = np.full((h + bar, max(2, h // 200), 3), 255, np.uint8)
    out = [panels[0]]
    for panel in panels[1:]:
        out += [gap, panel]
    return np.hstack(out)


__all__ = [
    "writer",
    "write_image",
    "write_bytes",
    "write_text",
    "encode_image",
    "write_ao",
    "labelled_sheet",
    "check_output_path",
    "replace_output",
    "check_output_dir",
    "check_own_output_dir",
    "mark_output_dir",
    "OUTPUT_MARK",
    "check_writable_ancestor",
    "check_not_inputs",
    "write_all_or_none",
    "IMAGE_SUFFIXES",
    "AO_SUFFIXES",
]
