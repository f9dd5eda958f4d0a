"""Bytes in, arrays out, and back: request bodies (JSON or ``.npz``) and answers (JSON or ``.npz``).

Arrays are never walked in Python: JSON lists go to ``np.asarray`` in one call, ``.npz`` members are read by
:mod:`service.npz` (no pickles) after their count, names and uncompressed sizes were checked (a tiny compressed
archive can claim gigabytes, or hold 36,000 members). The body is read in chunks and refused with 413 as soon as
it passes the limit, so a 64 MiB body costs at most the limit in memory; a job's ``.npz`` body goes to a file as
it arrives (:func:`spool_body`), not to memory.
"""

from __future__ import annotations

import asyncio
import io
import json
import math
from typing import Any, BinaryIO, Callable, Collection, Mapping, Optional, Union

import numpy as np
import orjson
from starlette.background import BackgroundTask
from starlette.requests import Request
from starlette.responses import Response

from . import memory
from .errors import BadRequest, InvalidInput, RequestTimeout, TooLarge, UnsupportedMediaType
from .npz import open_npz

JSON = "application/json"
NPZ = "application/x-npz"
XML_TYPES = ("application/xml", "text/xml")


def media_type(header: str | None) -> str:
    return (header or "").split(";", 1)[0].strip().lower()


#: the slowest upload rate allowed beyond DYNAMICS_READ_TIMEOUT (see read_body)
BODY_BYTES_PER_SECOND = 1 << 20
#: bytes of a spooled body gathered before they are written to its file, in a thread (see spool_body)
SPOOL_BLOCK = 1 << 20
#: what a refused body is told to do instead, by default
SMALLER = ("send smaller batches (the Python client splits them) or submit a job (POST /v1/jobs, client.submit)")


def declared_length(request: Request) -> Optional[int]:
    """The body's size as its Content-Length header declares it (None without one); 400 if it is no number."""
    declared = request.headers.get("content-length")
    if declared is None:
        return None
    try:
        n = int(declared)
    except ValueError:
        raise BadRequest("Content-Length: not a number", "Content-Length") from None
    if n < 0:
        raise BadRequest("Content-Length: negative", "Content-Length")
    return n


async def read_body(request: Request, limit: int, *, setting: str = "DYNAMICS_MAX_BODY_BYTES",
                    hint: str = SMALLER) -> bytes:
    """The request body, refused with 413 as soon as it is known to exceed ``limit`` bytes (the message names
    ``setting``, and says what to do instead: ``hint``)."""
    chunks: list[bytes] = []

    async def keep(chunk: bytes) -> None:
        chunks.append(chunk)

    await _receive(request, limit, setting, hint, keep)
    return b"".join(chunks)


async def spool_body(request: Request, limit: int, file: BinaryIO, *, setting: str = "DYNAMICS_MAX_BODY_BYTES",
                     hint: str = SMALLER) -> int:
    """The request body written to ``file`` as it arrives (the server holds at most :data:`SPOOL_BLOCK` of it),
    with :func:`read_body`'s limits; its size. The writes run in a thread: a disk may block, the event loop may
    not."""
    loop = asyncio.get_running_loop()
    block = bytearray()

    async def write(chunk: bytes) -> None:
        block.extend(chunk)
        if len(block) >= SPOOL_BLOCK:
            await loop.run_in_executor(None, file.write, bytes(block))
            block.clear()

    total = await _receive(request, limit, setting, hint, write)
    if block:
        await loop.run_in_executor(None, file.write, bytes(block))
    await loop.run_in_executor(None, file.flush)
    file.seek(0)
    return total


async def _receive(request: Request, limit: int, setting: str, hint: str, take: Callable[[bytes], Any]) -> int:
    """Hand each piece of the body to ``take`` (a coroutine function); its size. 413 as soon as it is known to
    be over ``limit`` (from Content-Length, before a byte is read), 408 past the read timeout."""
    declared = declared_length(request)
    if declared is not None and declared > limit:
        raise too_large(limit, setting, hint)
    deps = getattr(request.app.state, "deps", None)
    timeout = deps.settings.read_timeout if deps is not None else None
    loop = asyncio.get_running_loop()
    started = loop.time()
    total = 0
    stream = request.stream().__aiter__()
    while True:
        # The whole body is bounded, not only the gaps (a byte every few seconds would hold a connection for
        # ever): DYNAMICS_READ_TIMEOUT, plus a second per MiB received so that a large upload on a slow link
        # (1 MiB/s) still makes it.
        left = None if timeout is None else started + timeout + total / BODY_BYTES_PER_SECOND - loop.time()
        try:
            chunk = await asyncio.wait_for(stream.__anext__(), None if left is None else max(0.0, left))
        except StopAsyncIteration:
            break
        except asyncio.TimeoutError:
            raise RequestTimeout(f"body: not complete after {loop.time() - started:.0f} s ({total} bytes received; "
                                 f"DYNAMICS_READ_TIMEOUT is {timeout:g} s, plus 1 s per MiB); send the body at once",
                                 "body", headers={"Connection": "close"}) from None
        total += len(chunk)
        if total > limit:
            raise too_large(limit, setting, hint)
        if chunk:
            await take(chunk)
    return total


def too_large(limit: int, setting: str, hint: str = SMALLER) -> TooLarge:
    """413 for a body over ``limit`` bytes (``setting``), saying what to do instead; the connection is closed (the
    rest of the body is not read)."""
    return TooLarge(f"body: larger than the limit of {limit} bytes ({setting}); {hint}", "body",
                    headers={"Connection": "close"})


def decode(body: Union[bytes, BinaryIO], content_type: str | None, *, max_unpacked: int,
           names: Optional[Collection[str]] = None, check: Optional[Callable[[], None]] = None) -> dict[str, Any]:
    """A JSON object or an ``.npz`` archive (bytes, or a file) -> dict of plain values and arrays.

    ``names``: the fields the request takes; an ``.npz`` holding more members, or another one, is refused before
    any member is read. ``check()`` is called between the pieces of an ``.npz`` (the request's clock).
    No Content-Type means JSON; a header that names no media type (``;;;;``) is refused, not guessed."""
    kind = media_type(content_type) if content_type is not None else JSON
    if kind == NPZ:
        return decode_npz(body, max_unpacked=max_unpacked, names=names, check=check)
    if kind != JSON and not kind.endswith("+json"):
        raise UnsupportedMediaType(f"Content-Type: {kind or content_type!r:.64} is not accepted here; send {JSON} "
                                   f"or {NPZ}", "Content-Type")
    if not isinstance(body, bytes):
        body = body.read()
    if not body:
        raise InvalidInput("body: empty; expected a JSON object", "body")
    try:
        # NaN/Infinity literals are let through here so that the library's finiteness check names the field; so
        # are integers of thousands of digits (as floats, inf past 1e308: named by the same check), which
        # Python's int() would refuse with a ValueError.
        payload = json.loads(body, parse_int=_parse_int)
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InvalidInput(f"body: not valid JSON ({e})", "body") from None
    except RecursionError:
        raise InvalidInput("body: JSON nested too deeply", "body") from None
    if not isinstance(payload, dict):
        raise InvalidInput(f"body: expected a JSON object, got {type(payload).__name__}", "body")
    return payload


def _parse_int(text: str) -> int | float:
    return int(text) if len(text) <= 18 else float(text)


def decode_npz(body: Union[bytes, BinaryIO], *, max_unpacked: int, names: Optional[Collection[str]] = None,
               check: Optional[Callable[[], None]] = None) -> dict[str, Any]:
    """An .npz archive -> its members (:func:`service.npz.open_npz` checks them first); ``max_unpacked`` bounds
    what they occupy once read and made float64 (a few KB of compressed int8 can claim gigabytes of float64
    states). 0-d members are plain values: strings (an integrator, a JSON-encoded torque spec) and numbers."""
    out: dict[str, Any] = {}
    with open_npz(body, names=names, max_unpacked=max_unpacked) as archive:
        for name in archive.members:
            if check is not None:
                check()
            arr = archive.read(name, check)
            if arr.ndim == 0 and arr.dtype.kind == "U":
                out[name] = str(arr)
            elif arr.ndim == 0 and arr.dtype.kind in "fiub":
                out[name] = arr.item()
            else:
                out[name] = arr
    return out


def to_array(value: Any, name: str) -> np.ndarray:
    """A JSON number / list / list of lists (or an array from .npz) -> float64 array, or a 422 naming ``name``.

    Only what cannot become an array of numbers is refused here; shapes and finiteness are the library's to check.
    """
    if isinstance(value, np.ndarray):
        arr = value
    else:
        if isinstance(value, (str, bytes, dict, bool)) or value is None:
            raise InvalidInput(f"{name}: expected a number, a list of numbers or a list of lists, "
                            f"got {_json_type(value)}", name)
        try:
            arr = np.asarray(value)
        except ValueError:
            raise InvalidInput(f"{name}: rows of different lengths; expected a list of equal-length lists", name) \
                from None
    if arr.dtype.kind not in "fiu":
        what = "rows of different lengths" if arr.dtype.kind == "O" else f"elements of type {arr.dtype}"
        raise InvalidInput(f"{name}: expected numbers, got {what}", name)
    return np.asarray(arr, dtype=np.float64, order="C")  # (not ascontiguousarray: it makes 0-d arrays 1-d)


def _json_type(value: Any) -> str:
    return {str: "a string", bytes: "bytes", dict: "an object", bool: "a boolean"}.get(type(value), "null")


def wants_npz(accept: str | None) -> bool:
    return NPZ in (accept or "").lower()


def encode(result: Mapping[str, Any], accept: str | None, status: int = 200) -> Response:
    """Arrays and plain values -> a JSON or .npz answer, as the Accept header asks.

    In .npz, non-array values (e.g. a simulation report, a future ``scene``) travel as 0-d string arrays
    holding JSON, readable with ``allow_pickle=False``.
    """
    if wants_npz(accept):
        buf = io.BytesIO()
        members = {}
        for k, v in result.items():
            if isinstance(v, np.ndarray):
                members[k] = v
            else:
                members[k] = np.array(json.dumps(v, default=jsonable))
        np.savez(buf, **members)
        return _released(Response(buf.getvalue(), status_code=status, media_type=NPZ))
    # orjson writes float64 arrays straight from their memory (no tolist(), ~30x faster than json on 10k states)
    body = orjson.dumps(dict(result), default=jsonable, option=orjson.OPT_SERIALIZE_NUMPY)
    return _released(Response(body, status_code=status, media_type=JSON))


def _released(response: Response) -> Response:
    """A large answer's memory is given back to the system once it is sent (service.memory)."""
    if len(response.body) > memory.RELEASE_BYTES:
        response.background = BackgroundTask(memory.release)
    return response


def jsonable(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):  # (orjson: arrays it does not write itself, e.g. non-contiguous)
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        return obj.item()
    if isinstance(obj, (set, tuple)):
        return list(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def finite_or_none(x: float) -> float | None:
    """JSON has no infinity: absent limits (inf) become null."""
    x = float(x)
    return x if np.isfinite(x) else None


def finite_report(obj: Any) -> Any:
    """A simulation report made JSON: numpy scalars and arrays become plain values, NaN and infinity null (JSON
    has neither)."""
    if isinstance(obj, dict):
        return {str(k): finite_report(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite_report(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return finite_report(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if obj is None or isinstance(obj, (str, int, bool)):
        return obj
    return str(obj)
