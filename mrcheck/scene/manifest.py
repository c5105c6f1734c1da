"""The files of a scene manifest: its raw tables, the files each mesh needs, and writing it back.

A manifest (format 1, see :mod:`mrcheck.scene.model`) names one mesh file per part, but a mesh file
may need others to load or to be redistributable:

- ``.gltf``: its ``buffers[].uri`` (``.bin``) and ``images[].uri`` files (``data:`` URIs are
  embedded and need nothing);
- ``.obj``: the ``mtllib`` material files and the texture maps those name (``map_Kd`` ...);
- ``.dae``: the image files of its ``<init_from>`` elements;
- ``.urdf``: every ``<mesh filename>`` and ``<texture filename>`` (resolved the way the loader,
  yourdfpy, resolves them, ``package://`` included), each with its own companions; and, as
  :func:`notice_files`, the licence and source notes beside the URDF (``LICENSE*``,
  ``SOURCE*`` ...), or its package's licence one folder up, which must travel with a copied
  robot model.

``.glb``, ``.stl``, ``.ply`` and ``.off`` are self-contained. Companions that do not exist
(a URDF's collision ``.stl`` files are often left out) are skipped: the loader does not read
them either.

:func:`dumps_manifest` writes a manifest dictionary (as :func:`read_manifest` returns it) as
TOML in the layout of the shipped scenes: top-level keys, then ``[[parts]]`` and
``[[viewpoints]]`` tables, ``instances`` one inline table per line. Floats are written with
``repr``, so every number read back is bit-identical to the one written.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import re
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path
from urllib.parse import unquote

from mrcheck.core.errors import MrcheckError, display
from mrcheck.core.inputs import check_input
from mrcheck.core.partials import partial_prefix, remove_stale_partials
from mrcheck.scene import packages

# files beside a URDF that carry its licence and provenance (matched case-insensitively)
NOTICE_PREFIXES = ("license", "licence", "copying", "notice", "source", "authors", "readme")
LICENCE_PREFIXES = ("license", "licence", "copying", "notice")  # of those, the licence itself

_MTL_MAPS = re.compile(r"^\s*(map_\w+|bump|disp|decal|refl|norm)\s+(.+?)\s*$", re.IGNORECASE)
_DAE_IMAGE = re.compile(rb"<init_from>\s*([^<]+?)\s*</init_from>")
_IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tga", ".bmp", ".tif", ".tiff", ".gif", ".dds", ".webp")
_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def read_manifest(path) -> dict:
    """The raw tables of a manifest that :func:`mrcheck.scene.model.load_scene` has already accepted;
    a part's ``instances_file`` (an import's JSON list of instance tables) is read into its
    ``instances``, so that every consumer sees one form."""
    path = Path(path)
    check_input(path, "manifest")  # before opening: a FIFO would block the read for ever
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8-sig"))  # as mrcheck.scene.model reads it
        for part in data.get("parts", []):
            if isinstance(part, dict) and isinstance(part.get("instances_file"), str):
                part["instances"] = json.loads((path.parent / part.pop("instances_file")).read_text(encoding="utf-8"))
        return data
    except (OSError, UnicodeDecodeError, ValueError) as exc:  # TOMLDecodeError and JSON's are ValueErrors
        raise MrcheckError(f"cannot read manifest ({exc})", path) from None


# -- what a mesh file needs --------------------------------------------------------------------------
def _local(base: Path, name: str) -> Path | None:
    """``name`` (relative to the folder ``base``) when it is an existing file, else None."""
    name = unquote(name.strip().strip('"'))
    if not name or "://" in name or name.startswith("data:"):
        return None
    candidate = Path(os.path.normpath(base / name))
    return candidate if candidate.is_file() else None


def _obj_companions(path: Path) -> list[Path]:
    found = []
    with open(path, "rb") as handle:
        for raw in handle:
            if raw[:6] == b"mtllib":  # cheap test first: an OBJ can have millions of lines
                words = raw.decode("utf-8", "replace").split(None, 1)
                if len(words) == 2:
                    # a name may contain spaces; else several names separated by spaces
                    names = [words[1]] if _local(path.parent, words[1]) else words[1].split()
                    found += [p for p in (_local(path.parent, n) for n in names) if p]
    for mtl in list(found):
        for line in mtl.read_text(errors="replace").splitlines():
            match = _MTL_MAPS.match(line)
            if match:  # the file name is the last word; options such as -bm 0.5 come first
                texture = _local(mtl.parent, match.group(2)) or _local(mtl.parent, match.group(2).split()[-1])
                if texture:
                    found.append(texture)
    return found


def _gltf_companions(path: Path) -> list[Path]:
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError):
        return []  # the loader reports a broken file; here there is nothing more to find
    uris = [
        item.get("uri", "") for key in ("buffers", "images") for item in data.get(key, []) if isinstance(item, dict)
    ]
    return [p for p in (_local(path.parent, u) for u in uris if isinstance(u, str)) if p]


def _dae_companions(path: Path) -> list[Path]:
    names = [m.decode("utf-8", "replace") for m in _DAE_IMAGE.findall(path.read_bytes())]
    names = [n[len("file://") :] if n.startswith("file://") else n for n in names]
    return [p for p in (_local(path.parent, n) for n in names if n.lower().endswith(_IMAGE_SUFFIXES)) if p]


def _urdf_companions(path: Path) -> list[Path]:
    import yourdfpy

    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError):
        return []
    found = []
    logger = logging.getLogger("yourdfpy.urdf")
    quiet, logger.disabled = logger.disabled, True  # it warns about every missing collision mesh
    try:
        for element in root.iter():
            name = element.get("filename") if element.tag in ("mesh", "texture") else None
            if name:
                # the loader's own resolution (relative, package://, parent folders of the URDF)
                located = (
                    packages.resolve(name, packages.search_folders(path)) if name.startswith(packages.PREFIX) else None
                )
                resolved = Path(
                    os.path.normpath(located or yourdfpy.filename_handler_magic(name, dir=str(path.parent)))
                )
                if resolved.is_file():
                    found += mesh_files(resolved)
    finally:
        logger.disabled = quiet
    return found


_COMPANIONS = {".obj": _obj_companions, ".gltf": _gltf_companions, ".dae": _dae_companions, ".urdf": _urdf_companions}


def mesh_files(path) -> list[Path]:
    """The mesh file and every existing file it needs to load, first the mesh, each once."""
    path = Path(os.path.normpath(Path(path).absolute()))
    companions = _COMPANIONS.get(path.suffix.lower())
    try:
        found = companions(path) if companions and path.is_file() else []
    except OSError:  # unreadable (permissions, an I/O error): the mesh's loader says so, in one line
        found = []
    return list(dict.fromkeys([path, *found]))


def notice_files(path) -> list[Path]:
    """Licence and provenance files of a URDF (empty for other meshes), sorted: those beside it
    and, when there is no licence beside it, the licence files one folder up, where a robot
    package keeps the one licence of all its models (``pybullet_data/LICENSE.txt`` for
    ``pybullet_data/kuka_iiwa/model.urdf``, ``pkg/LICENSE`` for ``pkg/urdf/robot.urdf``)."""
    path = Path(os.path.normpath(Path(path).absolute()))
    if path.suffix.lower() != ".urdf" or not path.parent.is_dir():
        return []
    found = sorted(p for p in path.parent.iterdir() if p.is_file() and p.name.lower().startswith(NOTICE_PREFIXES))
    if not any(p.name.lower().startswith(LICENCE_PREFIXES) for p in found) and path.parent.parent != path.parent:
        # only licences up there: a README or SOURCE one folder up describes more than this robot
        found += sorted(
            p for p in path.parent.parent.iterdir() if p.is_file() and p.name.lower().startswith(LICENCE_PREFIXES)
        )
    return found


def scene_files(path) -> list[Path]:
    """Every file a scene loads from: a manifest and the files of each part's mesh
    (:func:`mesh_files`), or a single mesh file and its companions; a folder means its
    ``scene.toml``, as :func:`mrcheck.scene.model.load_scene` reads it."""
    path = Path(os.path.normpath(Path(path).absolute()))
    if path.is_dir():
        path = path / "scene.toml"
    if path.suffix.lower() != ".toml":
        return mesh_files(path)
    files = [path]
    try:
        parts = read_manifest(path).get("parts", [])
    except MrcheckError:
        return files
    for part in parts if isinstance(parts, list) else []:
        mesh = part.get("mesh") if isinstance(part, dict) else None
        if isinstance(mesh, str):
            files += mesh_files(path.parent / mesh)
        instances = part.get("instances_file") if isinstance(part, dict) else None
        if isinstance(instances, str):
            files.append(Path(os.path.normpath(path.parent / instances)))
    return list(dict.fromkeys(files))


def files_stamp(paths) -> str:
    """A digest of every file's path, size and modification time: it changes when an input is
    edited, replaced or touched (as make decides), without reading gigabytes of meshes."""
    digest = hashlib.sha256()
    for p in paths:
        name = os.fsencode(Path(p))  # the name's bytes: one that is not valid UTF-8 has no UTF-8 encoding
        try:
            st = os.stat(p)
            digest.update(b"%s\0%d\0%d\n" % (name, st.st_size, st.st_mtime_ns))
        except OSError:
            digest.update(b"%s\0missing\n" % name)
    return digest.hexdigest()[:16]


# -- writing a generated folder ----------------------------------------------------------------------
WORK_PREFIXES = (".mrcheck-partial-", ".mrcheck-old-")  # write_generated's hidden folders in OUTDIR


def remove_stale_work(outdir) -> None:
    """Remove what a killed :func:`write_generated` left in ``outdir`` (its hidden folders whose
    process is gone), so that the next run finds the folder as the last complete one left it."""
    for prefix in WORK_PREFIXES:
        remove_stale_partials(outdir, prefix)


def write_generated(outdir, fill, stale=()) -> None:
    """Write a generated folder (a scene, an as-built variant) into ``outdir``, replacing only
    what the command writes: other files there (a planner's photos and notes) stay.

    ``fill(work)`` writes every file into the empty folder ``work``, which lies hidden inside
    ``outdir`` (so that the moves below never cross a file system); then each top-level entry
    ``fill`` wrote, and each name of ``stale`` (entries an earlier run wrote and this one may
    not, such as ``scene_unit_missing.toml``), is moved aside, the new entries are moved in and
    the old ones deleted last. A failure at any step puts the old entries back, removes what
    was new (and ``outdir`` and its parents if this call made them), and is raised as
    MrcheckError when it is an OSError. ``outdir`` itself is never renamed: a shell or another
    process whose working folder it is keeps working there (``-o .``).
    """
    import shutil
    import tempfile

    outdir = Path(os.path.abspath(outdir))
    made = [p for p in [outdir, *outdir.parents] if not p.exists()]
    work: Path | None = None
    trash: Path | None = None
    moved_old: list[str] = []
    moved_new: list[str] = []
    try:
        outdir.mkdir(parents=True, exist_ok=True)
        remove_stale_work(outdir)
        work = Path(tempfile.mkdtemp(prefix=partial_prefix(WORK_PREFIXES[0]), dir=outdir))
        fill(work)
        new = sorted(p.name for p in work.iterdir())
        trash = Path(tempfile.mkdtemp(prefix=partial_prefix(WORK_PREFIXES[1]), dir=outdir))
        for name in sorted(set(new) | set(stale)):
            if os.path.lexists(outdir / name):
                os.rename(outdir / name, trash / name)
                moved_old.append(name)
        for name in new:
            os.rename(work / name, outdir / name)
            moved_new.append(name)
    except BaseException as exc:
        # undo in reverse: the new out, the old back (an entry moved means its folder was made)
        if work is not None:
            for name in moved_new:
                os.rename(outdir / name, work / name)
        if trash is not None:
            for name in moved_old:
                os.rename(trash / name, outdir / name)
        for folder in (work, trash):
            if folder is not None:
                shutil.rmtree(folder, ignore_errors=True)
        for folder in made:  # the folders made for this output, deepest first
            try:
                folder.rmdir()
            except OSError:
                break
        if isinstance(exc, OSError):
            raise MrcheckError(f"cannot write output ({exc.strerror or exc})", outdir) from None
        raise
    shutil.rmtree(work, ignore_errors=True)
    shutil.rmtree(trash, ignore_errors=True)


# -- writing TOML ------------------------------------------------------------------------------------
def _string(text: str) -> str:
    """A TOML basic string: JSON's string escapes (\\" \\\\ \\n \\t \\uXXXX) are exactly TOML's.
    TOML is UTF-8 and cannot hold a file name's undecodable bytes (surrogate escapes, which
    JSON would write as \\udcNN and TOML refuses): they are written as display() shows them."""
    return json.dumps(display(text), ensure_ascii=False)


def _key(key: str) -> str:
    return key if _BARE_KEY.match(key) else _string(key)


def _value(value) -> str:
    """One TOML value on one line (inline tables must be, in TOML 1.0)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        return repr(value)  # shortest round-trip form; 'inf', '-inf' and '1e-05' are TOML too
    if isinstance(value, str):
        return _string(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(v)}" for k, v in value.items()) + " }" if value else "{}"
    raise TypeError(f"cannot write {type(value).__name__} to a manifest")


def _table_lines(table: dict) -> list[str]:
    lines = []
    for key, value in table.items():
        if key == "instances" and isinstance(value, list) and value:
            lines += [f"{key} = ["] + [f"    {_value(item)}," for item in value] + ["]"]
        else:
            lines.append(f"{_key(key)} = {_value(value)}")
    return lines


def dumps_manifest(data: dict, header: str = "") -> str:
    """``data`` as manifest TOML; ``header`` becomes leading ``#`` comment lines."""
    lines = [f"# {line}".rstrip() for line in display(header).splitlines()]
    arrays = {k: v for k, v in data.items() if isinstance(v, list) and v and all(isinstance(t, dict) for t in v)}
    lines += _table_lines({k: v for k, v in data.items() if k not in arrays})
    for key, tables in arrays.items():
        for table in tables:
            lines += ["", f"[[{_key(key)}]]", *_table_lines(table)]
    return "\n".join(lines) + "\n"


__all__ = [
    "read_manifest",
    "mesh_files",
    "notice_files",
    "scene_files",
    "files_stamp",
    "dumps_manifest",
    "write_generated",
    "remove_stale_work",
    "NOTICE_PREFIXES",
]
