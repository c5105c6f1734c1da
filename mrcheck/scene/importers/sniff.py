"""What an ISO 10303-21 ("STEP physical file") really holds, read from its header and tail.

IFC and STEP share the file format; only the header's FILE_SCHEMA tells an IFC4 model from an
AP214 assembly. Checked before any library parses the file, so that a wrong extension, an
unknown schema or a truncated download is one clear line instead of a parser's message.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from mrcheck.core.errors import MrcheckError
from mrcheck.core.inputs import check_input

IFC_SUFFIXES = (".ifc",)
STEP_SUFFIXES = (".step", ".stp")
IMPORT_SUFFIXES = IFC_SUFFIXES + STEP_SUFFIXES
IFC_SCHEMAS = ("IFC2X3", "IFC4", "IFC4X3")  # what ifcopenshell 0.8+ reads (IFC4X3_ADD2 etc. are IFC4X3)
HEAD_BYTES = 1 << 16  # the header section is at most a few kB
TAIL_BYTES = 4096

_SCHEMA = re.compile(rb"FILE_SCHEMA\s*\(\s*\(\s*'([^']*)'", re.IGNORECASE)
_STEP_NAMES = {  # what a planner calls the application protocols (FILE_SCHEMA's first word)
    "CONFIG_CONTROL_DESIGN": "AP203",
    "AP203_CONFIGURATION_CONTROLLED_3D_DESIGN": "AP203 ed.2",
    "AUTOMOTIVE_DESIGN": "AP214",
    "AP242_MANAGED_MODEL_BASED_3D_ENGINEERING": "AP242",
}


@dataclass(frozen=True)
class FileKind:
    kind: str  # "ifc" or "step"
    schema: str  # as the header names it: "IFC4", "AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }"

    @property
    def label(self) -> str:
        """ "IFC4", "STEP AP214": how messages and summaries name the file's format."""
        if self.kind == "ifc":
            return self.schema
        name = self.schema.split()[0].upper() if self.schema else ""
        ap = next((v for k, v in _STEP_NAMES.items() if name.startswith(k)), "")
        return f"STEP {ap}" if ap else f"STEP ({name or 'no schema'})"


def ifc_schema_family(schema: str) -> str | None:
    """IFC2X3 / IFC4 / IFC4X3 for a schema ifcopenshell reads (IFC4X3_ADD2 -> IFC4X3), else None."""
    upper = schema.upper()
    for family in sorted(IFC_SCHEMAS, key=len, reverse=True):
        if upper == family or upper.startswith(family + "_") or (family == "IFC2X3" and upper.startswith("IFC2X3")):
            return family
    return None


def sniff(path) -> FileKind:
    """The kind and schema of a STEP-format file, checked against its extension.

    Raises MrcheckError naming the file for: an empty file, one that is not ISO 10303-21 (an
    ifcZIP, an ifcXML, a mesh), a truncated one (no ``END-ISO-10303-21;``), a header without
    FILE_SCHEMA, an IFC schema ifcopenshell does not read, and an extension that does not
    match the content (an AP214 file named .ifc).
    """
    path = Path(path)
    size = check_input(path, "model file").st_size
    if size == 0:
        raise MrcheckError("model file is empty", path)
    try:
        with open(path, "rb") as handle:
            head = handle.read(HEAD_BYTES)
            handle.seek(max(0, size - TAIL_BYTES))
            tail = handle.read()
    except OSError as exc:
        raise MrcheckError(f"cannot read model file ({exc.strerror or exc})", path) from None
    kind = _kind_from_header(head, path)
    if b"END-ISO-10303-21" not in tail.upper():
        raise MrcheckError(
            f"truncated {kind.label} file: it does not end with END-ISO-10303-21; "
            f"({size:,} bytes; an interrupted download or copy?)",
            path,
        )
    suffix = path.suffix.lower()
    if kind.kind == "ifc" and suffix in STEP_SUFFIXES:
        raise MrcheckError(f"the file is an IFC model ({kind.schema}), not a STEP part: rename it to .ifc", path)
    if kind.kind == "step" and suffix in IFC_SUFFIXES:
        raise MrcheckError(
            f"the file is a {kind.label} CAD file ({kind.schema.split()[0]}), not IFC: rename it to .step", path
        )
    if kind.kind == "ifc" and ifc_schema_family(kind.schema) is None:
        raise MrcheckError(f"unknown IFC schema {kind.schema!r} (mrcheck reads {', '.join(IFC_SCHEMAS)})", path)
    return kind


def _kind_from_header(head: bytes, path: Path) -> FileKind:
    start = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    if not start.upper().startswith(b"ISO-10303-21"):
        raise MrcheckError(f"not an IFC or STEP file: {_what_instead(start)}", path)
    match = _SCHEMA.search(head)
    if match is None:
        raise MrcheckError("broken header: no FILE_SCHEMA (('...')) in the HEADER section", path)
    schema = " ".join(match.group(1).decode("ascii", "replace").split())
    kind = "ifc" if schema.upper().startswith("IFC") else "step"
    return FileKind(kind, schema)


def _what_instead(start: bytes) -> str:
    """What the first bytes of a file that is not ISO 10303-21 look like."""
    if start.startswith(b"PK\x03\x04"):
        return "it is a ZIP archive (ifcZIP? unzip it and import the .ifc inside)"
    if start.startswith(b"<?xml") or start.startswith(b"<"):
        return "it is XML (ifcXML or STEP-XML are not read; export IFC-SPF / STEP AP214 or AP242)"
    if start.startswith(b"glTF"):
        return "it is a GLB mesh (give it to mrcheck as a mesh file, with the .glb extension)"
    return "it does not start with ISO-10303-21; (the STEP physical file header)"


def file_digest(path, chunk: int = 1 << 22) -> str:
    """SHA-256 of the file's bytes (the cache key: content, not name or time)."""
    import hashlib

    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while block := handle.read(chunk):
            digest.update(block)
    return digest.hexdigest()


__all__ = [
    "FileKind",
    "sniff",
    "file_digest",
    "ifc_schema_family",
    "IMPORT_SUFFIXES",
    "IFC_SUFFIXES",
    "STEP_SUFFIXES",
    "IFC_SCHEMAS",
]
