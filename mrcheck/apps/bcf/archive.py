"""A ``.bcfzip`` read without trusting it: a BCF file comes from another tool or another person,
and a zip's few kilobytes can unpack to gigabytes (a 30 kB file of 60 bzip2-compressed 60 MB
entries). So, before any entry is read, its central directory must stay within the limits
below: at most :data:`MAX_ENTRIES` entries, each name once, none encrypted, each stored or
deflated (what BCF tools write; zipfile inflates those in bounded steps, while one step of bzip2
or LZMA may unpack hundreds of megabytes), :data:`MAX_TOTAL` bytes unpacked in all. Entries are
then read in chunks with a running count, so an entry unpacking to more than its directory
says is stopped there (and zipfile's CRC check refuses it). Every refusal is a one-line
:class:`~mrcheck.core.errors.MrcheckError` saying what is wrong."""

from __future__ import annotations

import zipfile
import zlib

from mrcheck.core.errors import MrcheckError

MAX_ENTRIES = 20_000  # a topic is 2 or 3 entries (markup, viewpoint, snapshot): some 7,000 topics
MAX_TOTAL = 256 << 20  # bytes unpacked, all entries: a BCF's snapshots are PNG/JPEG, stored as they are
CHUNK = 1 << 16
SUPPORTED = {zipfile.ZIP_STORED: "stored", zipfile.ZIP_DEFLATED: "deflate"}
METHODS = {9: "deflate64", 12: "bzip2", 14: "LZMA", 93: "Zstandard", 98: "PPMd", 99: "AES encryption"}
# what zipfile, zlib and struct raise on a damaged archive: a bad CRC, a truncated or corrupt stream
DAMAGED = (zipfile.BadZipFile, zlib.error, EOFError, NotImplementedError, RuntimeError, ValueError, OSError)


def _mib(size: int) -> str:
    return f"{size / (1 << 20):.1f} MiB"


class BcfArchive:
    """An open ``.bcfzip`` whose directory passed the checks (see the module): :meth:`read` its
    entries by name. ``file``: a binary file object (seekable); ``path``: named in errors."""

    def __init__(self, file, path):
        self.path = path
        try:
            self.zip = zipfile.ZipFile(file)
        except zipfile.BadZipFile:
            raise MrcheckError("not a BCF file (.bcfzip is a zip archive)", path) from None
        except DAMAGED as exc:
            raise MrcheckError(f"damaged BCF file ({exc})", path) from None
        self.infos: dict[str, zipfile.ZipInfo] = {}
        self.unpacked = 0  # bytes read so far, of all entries
        try:
            self._check_directory()
        except BaseException:
            self.zip.close()
            raise

    def _check_directory(self) -> None:
        infos = self.zip.infolist()
        if len(infos) > MAX_ENTRIES:
            raise MrcheckError(f"BCF file has {len(infos)} entries (at most {MAX_ENTRIES} are read)", self.path)
        total = sum(i.file_size for i in infos)
        if total > MAX_TOTAL:
            raise MrcheckError(
                f"BCF file unpacks to {_mib(total)} (at most {_mib(MAX_TOTAL)}): a zip bomb, or snapshots too large",
                self.path,
            )
        for info in infos:
            if info.filename in self.infos:
                raise MrcheckError(f"BCF file has the entry {info.filename} twice", self.path)
            if info.flag_bits & 0x1:
                raise MrcheckError(f"BCF entry {info.filename} is encrypted (a BCF file is not)", self.path)
            if info.compress_type not in SUPPORTED:
                method = METHODS.get(info.compress_type, f"method {info.compress_type}")
                raise MrcheckError(
                    f"BCF entry {info.filename} is compressed with {method}: BCF files are deflated or stored",
                    self.path,
                )
            self.infos[info.filename] = info

    def names(self) -> list[str]:
        """The entries' names, in the archive's order."""
        return list(self.infos)

    def read(self, name: str, limit: int) -> bytes:
        """The bytes of entry ``name``, refused past ``limit`` bytes or past what the directory
        declares for it, whichever is less."""
        info = self.infos[name]
        bound = min(limit, info.file_size)
        if info.file_size > limit:
            raise MrcheckError(f"BCF entry {name} is {info.file_size} bytes (at most {limit})", self.path)
        data = bytearray()
        try:
            with self.zip.open(info) as entry:
                while chunk := entry.read(CHUNK):
                    self.unpacked += len(chunk)
                    if len(data) + len(chunk) > bound or self.unpacked > MAX_TOTAL:
                        raise MrcheckError(f"BCF entry {name} unpacks to more than its directory says", self.path)
                    data += chunk
        except DAMAGED as exc:
            raise MrcheckError(f"damaged BCF entry {name} ({exc})", self.path) from None
        return bytes(data)

    def close(self) -> None:
        self.zip.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


__all__ = ["BcfArchive", "MAX_ENTRIES", "MAX_TOTAL"]
