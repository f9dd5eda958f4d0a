"""The robot store: uploaded robots durable on disk, bundled robots read-only.

Store layout: one JSON file per uploaded robot, ``<store>/<id>.json``, holding the URDF text, the options it was
loaded with, a hash of the uploader's key and a summary of the model. A file is written to a temporary name,
flushed and fsync'ed, renamed over its final name and the directory fsync'ed, so that after a crash the robot is
either wholly there or not at all, and a 201 is only sent once the robot would survive a power cut.

Ids derive from the content: ``sha256(owner, floating_base, name, urdf)``, so the same upload twice gives the same
id, and two callers with different keys uploading the same file get two robots (neither can delete the other's).
Bundled robots (``robots/*.urdf``) are read-only and named by their file stem, as in the library and the CLI
(``planar_2r``); the spelling with dashes (``planar-2r``, the service's before) is accepted as an alias.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO, Iterator

from .errors import storage_full

ID_PATTERN = re.compile(r"^[a-z0-9][a-z0-9._-]{0,63}$")
_RECORD_VERSION = 1


@dataclass(frozen=True)
class RobotRecord:
    id: str
    name: str
    urdf: str
    floating_base: bool
    bundled: bool
    owner: str | None = None  # sha256 prefix of the uploader's API key; None when uploaded without keys
    created: float = 0.0
    summary: dict[str, Any] = field(default_factory=dict)  # nq, nv, joint_names, bodies, warnings


def owner_tag(api_key: str | None) -> str | None:
    """What the store remembers of a key: enough to compare, useless to an attacker reading the disk."""
    if not api_key:
        return None
    return hashlib.sha256(b"dynamics-owner\0" + api_key.encode()).hexdigest()[:32]


def robot_id(urdf: str, *, name: str, floating_base: bool, owner: str | None) -> str:
    h = hashlib.sha256()
    for part in (b"dynamics-robot-v1", (owner or "").encode(), b"1" if floating_base else b"0", name.encode(),
                 urdf.encode()):
        h.update(len(part).to_bytes(8, "little"))  # length-prefixed, so no two field splits collide
        h.update(part)
    return h.hexdigest()[:24]


def bundled_name(path: Path) -> str:
    return path.stem.lower()


def fsync_dir(path: Path) -> None:
    """Make a directory's entries (a rename, an unlink) durable."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_file(path: Path) -> Iterator[BinaryIO]:
    """A file object whose content replaces ``path`` only once it is complete and on disk: a crash at any
    moment leaves either the old file or the new one."""
    fd, tmp = tempfile.mkstemp(prefix="." + path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    fsync_dir(path.parent)


def atomic_write(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically and durably (:func:`atomic_file`)."""
    with atomic_file(path) as f:
        f.write(data)


@dataclass(frozen=True)
class IndexEntry:
    """What listing, access checks and quotas need of a stored robot, without its URDF."""
    id: str
    name: str
    owner: str | None
    floating_base: bool
    size: int  # bytes of the record on disk
    summary: dict[str, Any]


class RobotStore:
    """Uploaded robots on disk plus the bundled ones; safe to share between threads and processes."""

    def __init__(self, store_dir: Path, robots_dir: Path | None = None):
        self.dir = Path(store_dir)
        self.dir.mkdir(parents=True, exist_ok=True)
        for stale in self.dir.glob(".*.tmp"):  # a crash between mkstemp and rename leaves these behind
            try:
                stale.unlink()
            except OSError:
                pass
        self._bundled: dict[str, Path] = {}
        if robots_dir is not None and Path(robots_dir).is_dir():
            for p in sorted(Path(robots_dir).glob("*.urdf")):
                self._bundled[bundled_name(p)] = p
        self._bundled_cache: dict[str, RobotRecord] = {}
        self._lock = threading.Lock()
        self._index: dict[str, IndexEntry] = {}  # uploaded robots, by id (see index())

    # -- reading ---------------------------------------------------------------------------------------------
    def bundled_ids(self) -> list[str]:
        return list(self._bundled)

    def bundled_id(self, ref: str) -> str | None:
        """The bundled robot ``ref`` names ("planar_2r", or its alias "planar-2r"), None if none."""
        for candidate in (ref, ref.replace("-", "_")):
            if candidate in self._bundled:
                return candidate
        return None

    def _path(self, rid: str) -> Path:
        return self.dir / f"{rid}.json"

    def get(self, rid: str) -> RobotRecord | None:
        if not ID_PATTERN.match(rid):
            return None
        rid = self.bundled_id(rid) or rid
        if rid in self._bundled:
            with self._lock:
                rec = self._bundled_cache.get(rid)
            if rec is None:
                rec = RobotRecord(id=rid, name=rid, urdf=self._bundled[rid].read_text(encoding="utf-8"),
                                  floating_base=False, bundled=True)
                with self._lock:
                    self._bundled_cache[rid] = rec
            return rec
        try:
            raw = self._path(rid).read_bytes()
        except (FileNotFoundError, IsADirectoryError):
            return None
        d = json.loads(raw)
        return RobotRecord(id=d["id"], name=d["name"], urdf=d["urdf"], floating_base=bool(d["floating_base"]),
                           bundled=False, owner=d.get("owner"), created=float(d.get("created", 0.0)),
                           summary=d.get("summary", {}))

    def exists(self, rid: str) -> bool:
        return self.bundled_id(rid) is not None or (bool(ID_PATTERN.match(rid)) and self._path(rid).is_file())

    def uploaded_ids(self) -> list[str]:
        return sorted(self.index())

    def index(self) -> dict[str, IndexEntry]:
        """The uploaded robots, by id, without their URDFs. A record never changes once written (its id is its
        content's hash), so only files not seen before are read: listing 500 robots of 4 MB reads a directory,
        not 2 GB. Files written or deleted by another server process are picked up by the directory scan."""
        with os.scandir(self.dir) as it:
            present = {e.name[:-5]: e for e in it if e.name.endswith(".json") and ID_PATTERN.match(e.name[:-5])}
        with self._lock:
            known = dict(self._index)
        for rid, entry in present.items():
            if rid not in known:
                rec = self.get(rid)
                if rec is not None:
                    known[rid] = IndexEntry(rec.id, rec.name, rec.owner, rec.floating_base, entry.stat().st_size,
                                            rec.summary)
        known = {rid: e for rid, e in known.items() if rid in present}
        with self._lock:
            self._index = known
        return known

    def lookup(self, rid: str) -> IndexEntry | None:
        """The index entry of an uploaded robot, reading the directory only when the id is not known yet."""
        with self._lock:
            entry = self._index.get(rid)
        return entry if entry is not None or not ID_PATTERN.match(rid) else self.index().get(rid)

    def usage(self, owner: str | None) -> tuple[int, int]:
        """(robots, bytes) stored by ``owner`` (None: uploads made without keys)."""
        mine = [e for e in self.index().values() if e.owner == owner]
        return len(mine), sum(e.size for e in mine)

    # -- writing ---------------------------------------------------------------------------------------------
    def put(self, urdf: str, *, name: str, floating_base: bool, owner: str | None,
            summary: dict[str, Any]) -> tuple[RobotRecord, bool]:
        """Store a robot durably; returns (record, created) where created is False if it was already there."""
        rid = robot_id(urdf, name=name, floating_base=floating_base, owner=owner)
        existing = self.get(rid)
        if existing is not None:
            return existing, False
        rec = RobotRecord(id=rid, name=name, urdf=urdf, floating_base=floating_base, bundled=False, owner=owner,
                          created=time.time(), summary=summary)
        doc = {"version": _RECORD_VERSION, "id": rid, "name": name, "floating_base": floating_base,
               "owner": owner, "created": rec.created, "summary": summary, "urdf": urdf}
        data = json.dumps(doc).encode()
        try:
            atomic_write(self._path(rid), data)
        except OSError as e:  # (atomic_write leaves no temporary file behind)
            raise storage_full(e, f"the robot store {self.dir}") or e

        with self._lock:
            self._index[rid] = IndexEntry(rid, name, owner, floating_base, len(data), summary)
        return rec, True

    def delete(self, rid: str) -> bool:
        try:
            self._path(rid).unlink()
        except FileNotFoundError:
            return False
        with self._lock:
            self._index.pop(rid, None)
        fsync_dir(self.dir)
        return True
