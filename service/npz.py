"""Reading ``.npz`` archives (a zip of ``.npy`` members), from request bodies and from the job store, with every
cost bounded before it is paid.

Before any member is read (:func:`open_npz`):

* the members are counted from the archive's end record (its last 22 bytes, or the zip64 record they point to)
  and the central directory's size is bounded by that count, so that an archive of 36,000 empty members is
  refused without its directory being parsed (issue 49: reading them one by one, ~0.2 ms each, held a compute
  thread for 14 s);
* their names are checked against the fields the caller takes;
* each member's ``.npy`` header (shape, dtype) is read and checked against the bytes the member holds, and the
  arrays' total, counted as float64, against the caller's limit (a few KB of compressed int8 can claim gigabytes).

Then :meth:`Archive.read` reads one array in chunks into memory allocated once for it (the body is never copied
whole), calling the caller's ``check`` (the request's clock) between chunks.

Headers are parsed under :data:`HEADER_LOCK`. numpy reads an ``.npy`` header, a Python literal, with
``ast.literal_eval``, and CPython 3.11 keeps the AST constructor's recursion depth in interpreter-wide state
(since gh-95185): two threads converting at once, one interrupted by the other (a garbage collection that runs a
finalizer is enough), raise ``SystemError: AST constructor recursion depth mismatch`` (gh-106905; issue 49 saw
one 500 in 8,594 requests under load). A header takes ~20 us to parse, so the lock costs nothing measurable;
every ``.npy`` header the service reads goes through :func:`read_header`.
"""

from __future__ import annotations

import io
import math
import struct
import threading
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO, Callable, Collection, Optional, Union

import numpy as np
from numpy.lib import format as npformat

from .errors import InvalidInput, TooLarge, figure

#: serialises numpy's parsing of .npy headers (ast.literal_eval), see the module's docstring
HEADER_LOCK = threading.Lock()
#: members of an archive whose caller names none (the job store's files: a result has at most ~15)
MAX_MEMBERS = 64
#: bytes of central directory allowed per member: the 46 fixed bytes of an entry, its name, its extra fields
#: (zip64 sizes, timestamps) and a comment, generously; an archive whose directory is larger is refused unread
DIRECTORY_BYTES_PER_MEMBER = 1024
#: bytes read at once from a member (the clock is looked at between two)
CHUNK = 4 << 20
#: the longest .npy header read (numpy's own default limit)
MAX_HEADER = 10_000

_END = struct.Struct("<4s4H2LH")          # end of central directory record
_END64_LOCATOR = struct.Struct("<4sLQL")  # zip64 end record locator, just before it
_END64 = struct.Struct("<4sQ2H2L4Q")      # zip64 end of central directory record
#: what zipfile and zlib raise on a damaged archive (ValueError, RuntimeError for "encrypted", ...)
ZIP_ERRORS = (zipfile.BadZipFile, zipfile.LargeZipFile, NotImplementedError, OSError, EOFError, ValueError,
              RuntimeError, zlib.error, struct.error)

Source = Union[bytes, BinaryIO, Path]


@dataclass(frozen=True)
class Member:
    """One ``.npy`` member, as its header declares it (checked against the bytes it holds)."""
    name: str                # the field: the member's file name without ".npy"
    info: zipfile.ZipInfo
    shape: tuple[int, ...]
    dtype: np.dtype
    fortran_order: bool
    header_bytes: int        # where the array's bytes start in the member

    @property
    def nbytes(self) -> int:
        return math.prod(self.shape) * self.dtype.itemsize


def _shown(name: str) -> str:
    """A member's name for a message: cut (a zip entry's name may be 64 KB long)."""
    return name if len(name) <= 64 else name[:64] + "..."


def _not_npz(why: str) -> InvalidInput:
    return InvalidInput(f"body: not a valid .npz archive ({why[:200]})", "body")


def directory(f: BinaryIO) -> tuple[int, int]:
    """(members, bytes of the central directory) as the archive's end record states them; nothing else is read.

    The end record is the archive's last 22 bytes, before a comment of at most 64 KiB; an archive of more than
    65,535 members, or past 4 GiB, points from there to a zip64 record holding the same figures."""
    size = f.seek(0, io.SEEK_END)
    tail = min(size, _END.size + 0xFFFF)
    f.seek(size - tail)
    data = f.read(tail)
    at = data.rfind(b"PK\x05\x06")
    if at < 0 or at + _END.size > len(data):
        raise _not_npz("no zip end record")
    _, _, _, _, members, directory_bytes, directory_offset, _ = _END.unpack_from(data, at)
    if members == 0xFFFF or directory_bytes == 0xFFFFFFFF or directory_offset == 0xFFFFFFFF:
        end = size - tail + at
        if end < _END64_LOCATOR.size:
            raise _not_npz("no zip64 end record locator")
        f.seek(end - _END64_LOCATOR.size)
        signature, _, offset, _ = _END64_LOCATOR.unpack(f.read(_END64_LOCATOR.size))
        if signature != b"PK\x06\x07" or offset + _END64.size > size:
            raise _not_npz("no zip64 end record")
        f.seek(offset)
        record = f.read(_END64.size)
        if len(record) < _END64.size or record[:4] != b"PK\x06\x06":
            raise _not_npz("no zip64 end record")
        members, directory_bytes = _END64.unpack(record)[7:9]
    return members, directory_bytes


def read_header(f: BinaryIO) -> tuple[tuple[int, ...], bool, np.dtype]:
    """An .npy header (magic, version, the literal) -> (shape, fortran_order, dtype), parsed under
    :data:`HEADER_LOCK`. Raises ValueError (or EOFError) on a malformed header."""
    version = npformat.read_magic(f)
    # (3.0 only adds utf-8 field names of structured arrays: no numeric array needs it)
    read = {(1, 0): npformat.read_array_header_1_0, (2, 0): npformat.read_array_header_2_0}.get(version)
    if read is None:
        raise ValueError(f".npy version {version[0]}.{version[1]}; expected 1.0 or 2.0")
    with HEADER_LOCK:
        shape, fortran_order, dtype = read(f, max_header_size=MAX_HEADER)
    return tuple(shape), bool(fortran_order), np.dtype(dtype)


class Archive:
    """An open ``.npz`` whose members were counted, named and measured (:func:`open_npz`); :meth:`read` reads
    one of them. Use it as a context manager, or :meth:`close` it."""

    def __init__(self, zf: zipfile.ZipFile, members: dict[str, Member], owned: Optional[BinaryIO] = None):
        self.zf = zf
        self.members = members
        self.owned = owned  # the file opened for a path (zipfile closes only the files it opened itself)

    def __enter__(self) -> "Archive":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self.zf.close()
        if self.owned is not None:
            self.owned.close()

    def read(self, name: str, check: Optional[Callable[[], None]] = None) -> np.ndarray:
        """The member ``name``, read in chunks of :data:`CHUNK` bytes straight into its array; ``check()`` is
        called between two chunks (it raises to stop: the request's time budget)."""
        m = self.members[name]
        out = np.empty(math.prod(m.shape), dtype=m.dtype)
        try:
            with self.zf.open(m.info) as f:
                f.read(m.header_bytes)  # (the header, already parsed)
                raw = out.view(np.uint8) if m.nbytes else out
                done = 0
                while done < m.nbytes:
                    n = f.readinto(memoryview(raw[done:done + CHUNK]))
                    if not n:
                        raise EOFError(f"{m.nbytes - done} bytes missing")
                    done += n
                    if check is not None:
                        check()
        except ZIP_ERRORS as e:
            raise InvalidInput(f"{_shown(name)}: unreadable .npz member ({str(e)[:200]})", _shown(name)) from None
        # (Fortran order: the bytes are the transpose's in C order, as numpy.lib.format.read_array reads them)
        return out.reshape(m.shape[::-1]).transpose() if m.fortran_order else out.reshape(m.shape)

    def read_all(self, check: Optional[Callable[[], None]] = None) -> dict[str, np.ndarray]:
        out = {}
        for name in self.members:
            if check is not None:
                check()
            out[name] = self.read(name, check)
        return out


def open_npz(source: Source, *, names: Optional[Collection[str]] = None, max_unpacked: float = math.inf,
             max_members: Optional[int] = None) -> Archive:
    """Open an ``.npz`` and check it before any member is read: its member count (at most ``max_members``,
    default one per name of ``names``, else :data:`MAX_MEMBERS`), the size of its directory, each member's name
    (one of ``names`` when given, once), header and size, and the arrays' total counted as float64 against
    ``max_unpacked`` bytes. 422 (:class:`InvalidInput`) naming the member or ``body``, 413 (:class:`TooLarge`)
    for the size."""
    allowed = None if names is None else frozenset(names)
    limit = max_members if max_members is not None else (len(allowed) if allowed is not None else MAX_MEMBERS)
    owned = open(source, "rb") if isinstance(source, Path) else None
    f = owned or (io.BytesIO(source) if isinstance(source, bytes) else source)  # (BytesIO shares the bytes)
    zf = None
    try:
        try:
            count, directory_bytes = directory(f)
            if count > limit or directory_bytes > limit * DIRECTORY_BYTES_PER_MEMBER:
                fields = f" ({', '.join(sorted(allowed))})" if allowed is not None else ""
                raise InvalidInput(f"body: the .npz archive has {figure(count)} members in a directory of "
                                   f"{figure(directory_bytes)} bytes; this request takes at most {limit}, one per "
                                   f"field{fields}", "body")
            zf = zipfile.ZipFile(f)
        except ZIP_ERRORS as e:
            raise _not_npz(str(e)) from None
        return Archive(zf, _members(zf, allowed, limit, max_unpacked), owned)
    except BaseException:
        if zf is not None:
            zf.close()
        if owned is not None:
            owned.close()
        raise


def _members(zf: zipfile.ZipFile, allowed: Optional[frozenset[str]], limit: int,
             max_unpacked: float) -> dict[str, Member]:
    infos = zf.infolist()
    if len(infos) > limit:  # (an end record understating its directory)
        raise InvalidInput(f"body: the .npz archive has {len(infos)} members; this request takes at most {limit}",
                           "body")
    for info in infos:  # every name, before any member is opened
        name = info.filename.removesuffix(".npy")
        if allowed is not None and name not in allowed:
            raise InvalidInput(f"{_shown(name)}: unknown field; expected one of {', '.join(sorted(allowed))}",
                               _shown(name))
    unpacked = sum(i.file_size for i in infos)
    if unpacked > max_unpacked:
        raise unpacks_too_large(unpacked, max_unpacked)
    members: dict[str, Member] = {}
    as_float64 = 0
    for info in infos:
        m = _member(zf, info)
        if m.name in members:
            raise InvalidInput(f"{_shown(m.name)}: appears twice in the .npz archive", _shown(m.name))
        members[m.name] = m
        as_float64 += math.prod(m.shape) * max(8, m.dtype.itemsize)
        if as_float64 > max_unpacked:
            raise unpacks_too_large(as_float64, max_unpacked)
    return members


def _member(zf: zipfile.ZipFile, info: zipfile.ZipInfo) -> Member:
    """A member's header, checked against the bytes it holds, before any of its array is read."""
    name = _shown(info.filename.removesuffix(".npy"))
    try:
        with zf.open(info) as f:
            try:
                shape, fortran_order, dtype = read_header(f)
            except (ValueError, EOFError, SyntaxError, TypeError) as e:
                raise InvalidInput(f"{name}: .npz member is not in .npy format ({str(e)[:200]})", name) from None
            header = f.tell()
    except ZIP_ERRORS as e:
        raise _not_npz(str(e)) from None
    if dtype.hasobject:
        raise InvalidInput(f"{name}: .npz member holds Python objects; only numeric arrays are accepted", name)
    if any(n < 0 for n in shape):
        raise InvalidInput(f"{name}: .npz member declares a negative dimension {shape}", name)
    claimed = math.prod(shape) * dtype.itemsize
    if claimed != info.file_size - header:
        raise InvalidInput(f"{name}: .npz member declares {len(shape)} dimensions of {dtype} ({figure(claimed)} "
                           f"bytes) but holds {info.file_size - header} bytes", name)
    return Member(info.filename.removesuffix(".npy"), info, shape, dtype, fortran_order, header)


def unpacks_too_large(total: float, limit: float) -> TooLarge:
    return TooLarge(f"body: the .npz archive unpacks to {figure(total)} bytes (as float64), over the limit of "
                    f"{figure(limit)}; send smaller batches", "body")


def load(source: Source, **kwargs) -> dict[str, np.ndarray]:
    """Every member of a trusted ``.npz`` (the job store's files), headers parsed under the lock."""
    with open_npz(source, **kwargs) as archive:
        return archive.read_all()


def shapes(source: Source) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """Every member's (shape, dtype), from the headers only (no array is read)."""
    with open_npz(source) as archive:
        return {name: (m.shape, m.dtype) for name, m in archive.members.items()}
