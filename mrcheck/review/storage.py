"""Reviews and markers in SQLite (WAL): every change is committed before it is acknowledged."""

from __future__ import annotations

import sqlite3
import time
from pathlib import Path

from ..errors import MrcheckError

CATEGORIES = ("missing", "moved", "extra", "wrong size", "other", "suggested")
SEVERITIES = (1, 2, 3)
MAX_NOTE = 2000
# PRAGMA user_version of the database; 0 (before): marker coordinates in the pixels of the
# images served (at most 1280 wide); 1: in the photo's native pixels
VERSION = 1
_FIELDS = ("id", "shot", "x", "y", "category", "severity", "note", "part", "distance", "mode", "created", "updated")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS reviews (id INTEGER PRIMARY KEY, source TEXT NOT NULL, created REAL NOT NULL);
CREATE TABLE IF NOT EXISTS markers (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    review INTEGER NOT NULL REFERENCES reviews(id),
    shot TEXT NOT NULL, x REAL NOT NULL, y REAL NOT NULL,
    category TEXT NOT NULL, severity INTEGER NOT NULL, note TEXT NOT NULL DEFAULT '',
    part TEXT, distance REAL, mode TEXT,
    created REAL NOT NULL, updated REAL NOT NULL);
CREATE INDEX IF NOT EXISTS markers_shot ON markers(review, shot);
CREATE TABLE IF NOT EXISTS imported (review INTEGER NOT NULL, shot TEXT NOT NULL, key TEXT NOT NULL,
    PRIMARY KEY (review, shot, key));
"""


class Store:
    """One SQLite file; a short-lived connection per call (safe from any server thread)."""

    def __init__(self, path: Path, source_label: str, served_scales: dict | None = None):
        """``served_scales``: {shot name: (sx, sy)} served pixels per photo pixel of the shots
        served downscaled; a database of version 0 has their markers in served pixels."""
        self.path = Path(path)
        try:
            with self._connect() as db:
                version = db.execute("PRAGMA user_version").fetchone()[0]
                if version > VERSION:
                    raise MrcheckError(f"the review database is of a newer mrcheck (version {version}; "
                                       f"this one reads up to {VERSION})", self.path)
                db.execute("PRAGMA journal_mode=WAL")
                db.execute("BEGIN IMMEDIATE")   # the schema, the review and an upgrade: all or nothing
                for statement in filter(str.strip, _SCHEMA.split(";")):  # executescript would commit first
                    db.execute(statement)
                row = db.execute("SELECT id FROM reviews ORDER BY id LIMIT 1").fetchone()
                self.review = row[0] if row else db.execute("INSERT INTO reviews(source, created) VALUES (?, ?)",
                                                            (source_label, time.time())).lastrowid
                if version < 1:
                    for shot, (sx, sy) in (served_scales or {}).items():
                        db.execute("UPDATE markers SET x = x / ?, y = y / ? WHERE review = ? AND shot = ?",
                                   (sx, sy, self.review, shot))
                db.execute(f"PRAGMA user_version = {VERSION}")
                db.execute("COMMIT")
        except sqlite3.DatabaseError as exc:  # --db in a folder that cannot be written, or a file that is no database
            raise MrcheckError(f"cannot open the review database ({exc})", self.path) from None

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
            return [dict(r) for r in db.execute(sql + " ORDER BY id", args)]

    def get(self, marker_id: int) -> dict | None:
        with self._connect() as db:
            row = db.execute(f"SELECT {', '.join(_FIELDS)} FROM markers WHERE review = ? AND id = ?",
                             (self.review, marker_id)).fetchone()
            return dict(row) if row else None

    def add(self, values: dict) -> dict:
        with self._connect() as db:
            marker_id = self._insert(db, values)
        return self.get(marker_id)

    def _insert(self, db, values: dict) -> int:
        now = time.time()
        keys = ("shot", "x", "y", "category", "severity", "note", "part", "distance", "mode")
        return db.execute(
            f"INSERT INTO markers(review, {', '.join(keys)}, created, updated) VALUES (?, {', '.join('?' * len(keys))}, ?, ?)",
            (self.review, *[values.get(k) for k in keys], now, now)).lastrowid

    def imported_keys(self, shot: str) -> set[str]:
        """The keys of the suggestions imported into this review's ``shot`` before."""
        with self._connect() as db:
            return {row[0] for row in db.execute("SELECT key FROM imported WHERE review = ? AND shot = ?",
                                                 (self.review, shot))}

    def import_suggestions(self, shot: str, suggestions: list[dict]) -> int:
        """Add the suggestions whose ``key`` this review has not imported before (deleted ones
        stay deleted); returns how many were added. One transaction: a suggestion is recorded as imported
        exactly when its marker is written."""
        added = 0
        with self._connect() as db:
            db.execute("BEGIN IMMEDIATE")
            for s in suggestions:
                if db.execute("INSERT OR IGNORE INTO imported(review, shot, key) VALUES (?, ?, ?)",
                              (self.review, shot, s["key"])).rowcount:
                    self._insert(db, {**s, "shot": shot})
                    added += 1
            db.execute("COMMIT")   # on an exception the connection closes uncommitted: nothing is kept
        return added

    def update(self, marker_id: int, values: dict) -> dict | None:
        allowed = {k: v for k, v in values.items() if k in ("x", "y", "category", "severity", "note", "part", "distance", "mode")}
        if allowed:
            sets = ", ".join(f"{k} = ?" for k in allowed)
            with self._connect() as db:
                db.execute(f"UPDATE markers SET {sets}, updated = ? WHERE review = ? AND id = ?",
                           (*allowed.values(), time.time(), self.review, marker_id))
        return self.get(marker_id)

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
