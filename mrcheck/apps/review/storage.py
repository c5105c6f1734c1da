"""Reviews and markers in SQLite (WAL): every change is committed before it is acknowledged."""

from __future__ import annotations

import json
import sqlite3
import time
import uuid
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from mrcheck.apps.bcf import topic_guid
from mrcheck.core.errors import MrcheckError

CATEGORIES = ("missing", "moved", "extra", "wrong size", "other", "suggested")
SEVERITIES = (1, 2, 3)
MAX_NOTE = 2000
DEFAULT_STATUS = "Open"  # a marker's BCF status until one is set (in the review or by an import)
# PRAGMA user_version of the database; 0 (before): marker coordinates in the pixels of the
# images served (at most 1280 wide), and the first review used whatever was reviewed; 1: native
# pixels, one review per job, export or shots folder (reviews.source: its path relative to the database)
VERSION = 1
TABLES = {"reviews", "markers", "imported", "sqlite_sequence", "bcf"}  # a database with others is another program's
_FIELDS = (
    "id",
    "shot",
    "x",
    "y",
    "category",
    "severity",
    "note",
    "part",
    "distance",
    "mode",
    "created",
    "updated",
    "photo_offset",
)

SCHEMA = """
CREATE TABLE IF NOT EXISTS reviews (id INTEGER PRIMARY KEY, source TEXT NOT NULL, created REAL NOT NULL);
CREATE TABLE IF NOT EXISTS markers (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    review INTEGER NOT NULL REFERENCES reviews(id),
    shot TEXT NOT NULL, x REAL NOT NULL, y REAL NOT NULL,
    category TEXT NOT NULL, severity INTEGER NOT NULL, note TEXT NOT NULL DEFAULT '',
    part TEXT, distance REAL, mode TEXT,
    created REAL NOT NULL, updated REAL NOT NULL, photo_offset TEXT);
CREATE INDEX IF NOT EXISTS markers_shot ON markers(review, shot);
CREATE TABLE IF NOT EXISTS imported (review INTEGER NOT NULL, shot TEXT NOT NULL, key TEXT NOT NULL,
    PRIMARY KEY (review, shot, key));
CREATE TABLE IF NOT EXISTS bcf (review INTEGER NOT NULL, marker INTEGER NOT NULL, status TEXT NOT NULL,
    comments TEXT NOT NULL, PRIMARY KEY (review, marker));
"""


def _marker(row) -> dict:
    """A marker row as the API answers it: its offset decoded (None: not measured)."""
    marker = dict(row)
    stored = marker.pop("photo_offset")
    marker["offset"] = json.loads(stored) if stored else None
    return marker


@dataclass(frozen=True)
class BcfChange:
    """What a BCF import sets on one marker: its status, the comments it adds (those the marker
    has not got yet: none is ever removed) and, when the topic's priority says one, its severity."""

    marker: int
    status: str
    comments: list  # dicts of guid, date, author, text
    severity: int | None = None


@dataclass(frozen=True)
class BcfMarker:
    """A marker a BCF import adds for a topic of another tool: the marker's fields (shot, x, y,
    category, severity, note, part), the topic's GUID (a later import matches it), its status,
    comments and creation time (seconds since the epoch)."""

    values: dict
    guid: str
    status: str
    comments: list
    created: float | None  # None: now


def merged_comments(old: list, new: list) -> list:
    """``old`` and then the comments of ``new`` it lacks (by GUID; by date, author and text for
    a comment without one): an import adds comments, it never removes one."""

    def key(c: dict) -> tuple:
        return (c.get("guid"),) if c.get("guid") else (c.get("date"), c.get("author"), c.get("text"))

    seen = {key(c) for c in old}
    added = []
    for c in new:
        if key(c) not in seen:
            seen.add(key(c))
            added.append(c)
    return [*old, *added]


class Store:
    """One SQLite file; a short-lived connection per call (safe from any server thread)."""

    def __init__(self, path: Path, review: str, served_scales: dict | None = None):
        """The review named ``review`` (:meth:`.source.Source.review_name`) in the database at
        ``path``, created when new; the database's other reviews stay apart (``self.others``).
        ``served_scales``: {shot name: (sx, sy)} served pixels per photo pixel of the shots served
        downscaled; a database of version 0 has their markers in served pixels."""
        self.path = Path(path)
        try:
            with self._connect() as db:
                version = db.execute("PRAGMA user_version").fetchone()[0]
                foreign = {row[0] for row in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")} - TABLES
                if foreign:  # checked before anything is written into it (WAL mode, our tables)
                    raise MrcheckError(
                        f"not a review database (it has the table(s) {', '.join(sorted(foreign))}): "
                        "give a new file with --db",
                        self.path,
                    )
                if version > VERSION:
                    raise MrcheckError(
                        f"the review database is of a newer mrcheck (version {version}; "
                        f"this one reads up to {VERSION})",
                        self.path,
                    )
                db.execute("PRAGMA journal_mode=WAL")
                db.execute("BEGIN IMMEDIATE")  # the schema, the review and an upgrade: all or nothing
                for statement in filter(str.strip, SCHEMA.split(";")):  # executescript would commit first
                    db.execute(statement)
                self.review, self.created = self._review(db, review, version)
                self._add_guids(db)
                self._add_offsets(db)
                if version < 1:
                    for shot, (sx, sy) in (served_scales or {}).items():
                        db.execute(
                            "UPDATE markers SET x = x / ?, y = y / ? WHERE review = ? AND shot = ?",
                            (sx, sy, self.review, shot),
                        )
                db.execute(f"PRAGMA user_version = {VERSION}")
                db.execute("COMMIT")
                self.others = [
                    row[0] for row in db.execute("SELECT source FROM reviews WHERE id != ? ORDER BY id", (self.review,))
                ]
        except sqlite3.DatabaseError as exc:  # --db in a folder that cannot be written, or a file that is no database
            raise MrcheckError(f"cannot open the review database ({exc})", self.path) from None

    @staticmethod
    def _review(db, name: str, version: int) -> tuple[int, bool]:
        """The id of the review ``name`` and whether it is new. A database of version 0 has one
        review, used by whatever was reviewed with it: the first review to open it adopts it."""
        row = db.execute("SELECT id FROM reviews WHERE source = ?", (name,)).fetchone()
        if row is None and version < 1:
            row = db.execute("SELECT id FROM reviews ORDER BY id LIMIT 1").fetchone()
            if row is not None:
                db.execute("UPDATE reviews SET source = ? WHERE id = ?", (name, row[0]))
        if row is not None:
            return row[0], False
        return db.execute("INSERT INTO reviews(source, created) VALUES (?, ?)", (name, time.time())).lastrowid, True

    def _add_guids(self, db) -> None:
        """Every marker's BCF topic GUID (markers.guid): a random uuid4 given when the marker is
        made, so no other page can guess it. A database without the column gets it here, and a
        marker without a GUID (made before, or by an earlier mrcheck using this database) gets
        the one its exports had (uuid5 of the database path, review and id), so a BIM tool
        holding its topic still finds it."""
        if "guid" not in {row[1] for row in db.execute("PRAGMA table_info(markers)")}:
            db.execute("ALTER TABLE markers ADD COLUMN guid TEXT")
        for row in db.execute("SELECT id, review FROM markers WHERE guid IS NULL").fetchall():
            legacy = topic_guid("review", self.path.resolve(), row["review"], row["id"])
            db.execute("UPDATE markers SET guid = ? WHERE id = ?", (legacy, row["id"]))

    @staticmethod
    def _add_offsets(db) -> None:
        """markers.photo_offset (JSON of :meth:`.measure.PhotoOffset.to_dict`, NULL: not measured) in a
        database made before it; an older mrcheck reading the database ignores the column."""
        if "photo_offset" not in {row[1] for row in db.execute("PRAGMA table_info(markers)")}:
            db.execute("ALTER TABLE markers ADD COLUMN photo_offset TEXT")

    def _connect(self):
        db = sqlite3.connect(self.path, timeout=10, isolation_level=None)  # autocommit: each statement commits
        db.execute("PRAGMA synchronous=FULL")
        db.row_factory = sqlite3.Row
        return _Closing(db)

    def markers(self, shot: str | None = None) -> list[dict]:
        with self._connect() as db:
            sql = f"SELECT {', '.join(_FIELDS)} FROM markers WHERE review = ?"
            args = [self.review]
            if shot is not None:
                sql += " AND shot = ?"
                args.append(shot)
            return [_marker(r) for r in db.execute(sql + " ORDER BY id", args)]

    def get(self, marker_id: int) -> dict | None:
        with self._connect() as db:
            row = db.execute(
                f"SELECT {', '.join(_FIELDS)} FROM markers WHERE review = ? AND id = ?", (self.review, marker_id)
            ).fetchone()
            return _marker(row) if row else None

    def set_offset(self, marker_id: int, offset: dict | None) -> dict | None:
        """Store the marker's measured offset (None: clear it); the marker as it is now."""
        with self._connect() as db:
            db.execute(
                "UPDATE markers SET photo_offset = ?, updated = ? WHERE review = ? AND id = ?",
                (None if offset is None else json.dumps(offset), time.time(), self.review, marker_id),
            )
        return self.get(marker_id)

    def add(self, values: dict) -> dict:
        with self._connect() as db:
            marker_id = self._insert(db, values)
        return self.get(marker_id)

    def _insert(self, db, values: dict, guid: str | None = None, created: float | None = None) -> int:
        """A new marker; ``guid``: its BCF topic's (a topic another tool made), else a new uuid4."""
        now = time.time()
        created = now if created is None else created
        keys = ("shot", "x", "y", "category", "severity", "note", "part", "distance", "mode")
        columns, slots = ", ".join(keys), ", ".join("?" * len(keys))
        return db.execute(
            f"INSERT INTO markers(review, {columns}, created, updated, guid) VALUES (?, {slots}, ?, ?, ?)",
            (self.review, *[values.get(k) for k in keys], created, created, guid or str(uuid.uuid4())),
        ).lastrowid

    def guids(self) -> dict[int, str]:
        """{marker id: its BCF topic GUID} of this review's markers."""
        with self._connect() as db:
            return {r[0]: r[1] for r in db.execute("SELECT id, guid FROM markers WHERE review = ?", (self.review,))}

    def imported_keys(self, shot: str) -> set[str]:
        """The keys of the suggestions imported into this review's ``shot`` before."""
        with self._connect() as db:
            return {
                row[0]
                for row in db.execute("SELECT key FROM imported WHERE review = ? AND shot = ?", (self.review, shot))
            }

    def import_suggestions(self, shot: str, suggestions: list[dict]) -> int:
        """Add the suggestions whose ``key`` this review has not imported before (deleted ones
        stay deleted); returns how many were added. One transaction: a suggestion is recorded as imported
        exactly when its marker is written."""
        added = 0
        with self._connect() as db:
            db.execute("BEGIN IMMEDIATE")
            for s in suggestions:
                if db.execute(
                    "INSERT OR IGNORE INTO imported(review, shot, key) VALUES (?, ?, ?)", (self.review, shot, s["key"])
                ).rowcount:
                    self._insert(db, {**s, "shot": shot})
                    added += 1
            db.execute("COMMIT")  # on an exception the connection closes uncommitted: nothing is kept
        return added

    def update(self, marker_id: int, values: dict) -> dict | None:
        allowed = {
            k: v
            for k, v in values.items()
            if k in ("x", "y", "category", "severity", "note", "part", "distance", "mode")
        }
        if allowed:
            sets = ", ".join(f"{k} = ?" for k in allowed)
            with self._connect() as db:
                db.execute(
                    f"UPDATE markers SET {sets}, updated = ? WHERE review = ? AND id = ?",
                    (*allowed.values(), time.time(), self.review, marker_id),
                )
        return self.get(marker_id)

    def bcf_states(self) -> dict:
        """{marker id: {"status": ..., "comments": [...]}} of the markers a BCF import touched."""
        with self._connect() as db:
            rows = db.execute("SELECT marker, status, comments FROM bcf WHERE review = ?", (self.review,))
            return {r["marker"]: {"status": r["status"], "comments": json.loads(r["comments"])} for r in rows}

    def apply_bcf(self, changes: list[BcfChange], new: tuple | list = ()) -> None:
        """A BCF import in one transaction: markers' status, comments added to theirs (none
        removed), new severities; and the markers of topics another tool made (``new``)."""
        now = time.time()
        with self._connect() as db:
            db.execute("BEGIN IMMEDIATE")
            for c in changes:
                self._set_bcf(db, c.marker, c.status, c.comments)
                if c.severity is not None:
                    db.execute(
                        "UPDATE markers SET severity = ?, updated = ? WHERE review = ? AND id = ? AND severity != ?",
                        (c.severity, now, self.review, c.marker, c.severity),
                    )
            for m in new:
                self._set_bcf(db, self._insert(db, m.values, m.guid, m.created), m.status, m.comments)
            db.execute("COMMIT")  # on an exception the connection closes uncommitted: nothing is kept

    def _set_bcf(self, db, marker: int, status: str | None, comments: list) -> None:
        """The marker's status (None: kept) and its comments with ``comments`` added."""
        row = db.execute("SELECT status, comments FROM bcf WHERE review = ? AND marker = ?", (self.review, marker))
        row = row.fetchone()
        old = json.loads(row["comments"]) if row else []
        status = status if status is not None else (row["status"] if row else DEFAULT_STATUS)
        db.execute(
            "INSERT OR REPLACE INTO bcf(review, marker, status, comments) VALUES (?, ?, ?, ?)",
            (self.review, marker, status, json.dumps(merged_comments(old, comments), ensure_ascii=False)),
        )

    def set_status(self, marker_id: int, status: str) -> None:
        """The marker's BCF status, set in the review (a change: ``updated`` too)."""
        with self._connect() as db:
            db.execute("BEGIN IMMEDIATE")
            self._set_bcf(db, marker_id, status, [])
            db.execute(
                "UPDATE markers SET updated = ? WHERE review = ? AND id = ?", (time.time(), self.review, marker_id)
            )
            db.execute("COMMIT")

    def add_comment(self, marker_id: int, author: str, text: str) -> dict:
        """A comment written in the review (a new GUID, now, ``author``) added to the marker's."""
        comment = {
            "guid": str(uuid.uuid4()),
            "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "author": author,
            "text": text,
        }
        with self._connect() as db:
            db.execute("BEGIN IMMEDIATE")
            self._set_bcf(db, marker_id, None, [comment])
            db.execute("COMMIT")
        return comment

    def delete(self, marker_id: int) -> bool:
        with self._connect() as db:
            return db.execute("DELETE FROM markers WHERE review = ? AND id = ?", (self.review, marker_id)).rowcount > 0


class _Closing:
    def __init__(self, db):
        self.db = db

    def __enter__(self):
        return self.db

    def __exit__(self, *exc):
        self.db.close()
