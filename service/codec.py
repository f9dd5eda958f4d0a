"""Bytes in, arrays out, and back: request bodies (JSON or ``.npz``) and answers (JSON or ``.npz``).

Arrays are never walked in Python: JSON lists go to ``np.asarray`` in one call, ``.npz`` members are read with
``allow_pickle=False`` after their uncompressed sizes were checked (a tiny compressed archive can claim
gigabytes). The body is read in chunks and refused with 413 as soon as it passes the limit, so a 64 MiB body
costs at most the limit in memory.
"""

from __future__ import annotations

import asyncio
import io
import json
import math
import zipfile
import zlib
from typing import Any, Mapping

import numpy as np
import orjson
from starlette.background import BackgroundTask
from starlette.requests import Request
from starlette.responses import Response

from . import memory
from .errors import BadRequest, InvalidInput, RequestTimeout, TooLarge, UnsupportedMediaType, figure

JSON = "application/json"
NPZ = "application/x-npz"
XML_TYPES = ("application/xml", "text/xml")


def media_type(header: str | None) -> str:
    return (header or "").split(";", 1)[0].strip().lower()


#: the slowest upload rate allowed beyond DYNAMICS_READ_TIMEOUT (see read_body)
BODY_BYTES_PER_SECOND = 1 << 20


async def read_body(request: Request, limit: int) -> bytes:
    """The request body, refused with 413 as soon as it is known to exceed ``limit`` bytes."""
    declared = request.headers.get("content-length")
    if declared is not None:
        try:
            n = int(declared)
        except ValueError:
            raise BadRequest("Content-Length: not a number", "Content-Length") from None
        if n > limit:
            raise _too_large(limit)
    deps = getattr(request.app.state, "deps", None)
    timeout = deps.settings.read_timeout if deps is not None else None
    loop = asyncio.get_running_loop()
    started = loop.time()
    chunks: list[bytes] = []
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
            raise _too_large(limit)
        chunks.append(chunk)
    return b"".join(chunks)


def _too_large(limit: int) -> TooLarge:
    return TooLarge(f"body: larger than the limit of {limit} bytes (DYNAMICS_MAX_BODY_BYTES); send smaller batches "
                    f"(the Python client splits them) or submit a job (POST /v1/jobs, client.submit)", "body",
                    headers={"Connection": "close"})


def decode(body: bytes, content_type: str | None, *, max_unpacked: int) -> dict[str, Any]:
    """A JSON object or an ``.npz`` archive -> dict of plain values and arrays.

    No Content-Type means JSON; a header that names no media type (``;;;;``) is refused, not guessed."""
    kind = media_type(content_type) if content_type is not None else JSON
    if kind == NPZ:
        return decode_npz(body, max_unpacked=max_unpacked)
    if kind != JSON and not kind.endswith("+json"):
        raise UnsupportedMediaType(f"Content-Type: {kind or content_type!r:.64} is not accepted here; send {JSON} "
                                   f"or {NPZ}", "Content-Type")
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


def _member_header(zf: zipfile.ZipFile, info: zipfile.ZipInfo) -> tuple[tuple[int, ...], np.dtype]:
    """The shape and dtype an .npy member declares, checked against the bytes it holds, before it is read."""
    name = info.filename.removesuffix(".npy")
    with zf.open(info) as f:
        try:
            version = np.lib.format.read_magic(f)
            read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) else \
                np.lib.format.read_array_header_2_0
            shape, _, dtype = read_header(f, max_header_size=10_000)
        except (ValueError, EOFError, SyntaxError, TypeError) as e:
            raise InvalidInput(f"{name}: .npz member is not in .npy format ({str(e)[:200]})", name) from None
        header = f.tell()
    if dtype.hasobject:
        raise InvalidInput(f"{name}: .npz member holds Python objects; only numeric arrays are accepted", name)
    claimed = math.prod(shape) * dtype.itemsize
    if claimed != info.file_size - header:
        raise InvalidInput(f"{name}: .npz member declares {len(shape)} dimensions of {dtype} ({figure(claimed)} "
                           f"bytes) but holds {info.file_size - header} bytes", name)
    return shape, dtype


def decode_npz(body: bytes, *, max_unpacked: int) -> dict[str, Any]:
    """An .npz archive -> its members; ``max_unpacked`` bounds what they occupy once read and made float64
    (a few KB of compressed int8 can claim gigabytes of float64 states)."""
    buf = io.BytesIO(body)
    try:
        with zipfile.ZipFile(buf) as zf:
            infos = zf.infolist()
            if sum(i.file_size for i in infos) > max_unpacked:
                raise _unpacks_too_large(sum(i.file_size for i in infos), max_unpacked)
            total = 0
            for info in infos:
                shape, dtype = _member_header(zf, info)
                total += math.prod(shape) * max(8, dtype.itemsize)
            if total > max_unpacked:
                raise _unpacks_too_large(total, max_unpacked)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, NotImplementedError, OSError, EOFError, ValueError,
            RuntimeError, zlib.error) as e:  # (zipfile: ValueError, zlib.error, RuntimeError for "encrypted")
        raise InvalidInput(f"body: not a valid .npz archive ({str(e)[:200]})", "body") from None
    out: dict[str, Any] = {}
    buf.seek(0)  # (np.load reads the magic from where the headers were last read)
    try:
        with np.load(buf, allow_pickle=False) as npz:
            for name in npz.files:
                arr = npz[name]
                if arr.ndim == 0 and arr.dtype.kind == "U":
                    out[name] = str(arr)  # strings (integrator, a JSON-encoded torque spec) as 0-d arrays
                elif arr.ndim == 0 and arr.dtype.kind in "fiub":
                    out[name] = arr.item()
                else:
                    out[name] = arr
    except ValueError as e:  # object arrays (pickles) and malformed members
        raise InvalidInput(f"body: .npz member refused ({str(e)[:200]}); only numeric arrays are accepted",
                           "body") from None
    except (OSError, EOFError, zipfile.BadZipFile, NotImplementedError, RuntimeError, zlib.error) as e:
        raise InvalidInput(f"body: unreadable .npz archive ({str(e)[:200]})", "body") from None
    return out


def _unpacks_too_large(total: int, limit: int) -> TooLarge:
    return TooLarge(f"body: the .npz archive unpacks to {figure(total)} bytes (as float64), over the limit of "
                    f"{limit}; "
                    f"send smaller batches", "body")


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
