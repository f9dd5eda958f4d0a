"""Python client of the dynamics service: the library's names and shapes, over HTTP.

    >>> from service.client import Client
    >>> with Client("http://127.0.0.1:8000") as client:
    ...     robot = client.robot("planar-2r")             # or client.upload("my_arm.urdf")
    ...     tau = robot.inverse_dynamics(q, v, a)         # numpy in, numpy out; (nq,) or (B, nq)
    ...     traj = robot.simulate(q0, v0, 1.0, torque={"type": "zero"})
    ...     tau1 = robot.inverse_dynamics(q[:1], v[:1], a[:1], locked={"joint2": 0.3})  # joint1 moves alone
    ...     robot.last_scene                    # {"locked": {"joint2": 0.3}, "skipped": [...], "nv": 1, ...}

Batches of more than :data:`NPZ_THRESHOLD` numbers travel as ``.npz`` both ways (no JSON number formatting
or parsing); smaller requests use JSON. Every failure raises :class:`ServiceError` with the HTTP status, the
server's message (naming the field at fault) and its machine-readable code.
"""

from __future__ import annotations

import io
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Optional, Union

import httpx
import numpy as np

NPZ = "application/x-npz"
JSON = "application/json"
#: requests carrying more numbers than this are sent and answered as .npz
NPZ_THRESHOLD = 2048


class ServiceError(Exception):
    """The service refused or failed a request: ``status`` (HTTP, 0 if unreachable), ``message``, ``code``."""

    def __init__(self, status: int, message: str, code: str = "error", field: Optional[str] = None):
        super().__init__(f"{status}: {message}" if status else message)
        self.status = status
        self.message = message
        self.code = code
        self.field = field


@dataclass
class Trajectory:
    """What ``Robot.simulate`` returns: sample times t (K,), q (K, nq), v (K, nv), tau (K, nv), and the report."""
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    tau: np.ndarray
    report: dict = field(default_factory=dict)


def _as_array(x: Any) -> np.ndarray:
    return np.asarray(x, dtype=np.float64)


class Client:
    """A connection pool to one service; use as a context manager or call :meth:`close`."""

    def __init__(self, base_url: str, api_key: Optional[str] = None, timeout: float = 60.0,
                 npz_threshold: int = NPZ_THRESHOLD, time_budget: Optional[float] = None):
        """``time_budget``: seconds of server work per request (at most the server's own budget); a request
        past it fails with ServiceError 504."""
        headers = {"Authorization": f"Bearer {api_key}"} if api_key else {}
        if time_budget is not None:
            headers["X-Time-Budget"] = repr(float(time_budget))
        self.base_url = base_url.rstrip("/")
        self.npz_threshold = npz_threshold
        self._http = httpx.Client(base_url=self.base_url, headers=headers, timeout=timeout)

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def close(self) -> None:
        self._http.close()

    # -- plumbing --------------------------------------------------------------------------------------------
    def request(self, method: str, path: str, **kwargs: Any) -> httpx.Response:
        try:
            r = self._http.request(method, path, **kwargs)
        except httpx.TimeoutException as e:
            raise ServiceError(0, f"no answer from {self.base_url} in time: {e}", "timeout") from None
        except httpx.TransportError as e:
            raise ServiceError(0, f"cannot reach {self.base_url}: {e}", "unreachable") from None
        if r.status_code >= 400:
            try:
                body = r.json()
                raise ServiceError(r.status_code, str(body.get("detail", r.text)), body.get("code", "error"),
                                   body.get("field"))
            except (ValueError, AttributeError):
                raise ServiceError(r.status_code, r.text or r.reason_phrase) from None
        return r

    def call(self, path: str, payload: Mapping[str, Any], *, npz_answer: bool = False) -> dict[str, Any]:
        """POST ``payload`` (numpy arrays and plain values); .npz both ways when it is large, and for the
        answer when ``npz_answer`` (a trajectory is large even when its request is small)."""
        arrays = {k: v for k, v in payload.items() if isinstance(v, np.ndarray)}
        size = sum(a.size for a in arrays.values())
        if size > self.npz_threshold:
            buf = io.BytesIO()
            members = {k: (v if isinstance(v, np.ndarray) else np.array(v if not isinstance(v, (dict, list))
                                                                          else json.dumps(v)))
                       for k, v in payload.items() if v is not None}
            np.savez(buf, **members)
            r = self.request("POST", path, content=buf.getvalue(),
                             headers={"Content-Type": NPZ, "Accept": NPZ})
        else:
            body = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in payload.items() if v is not None}
            r = self.request("POST", path, content=json.dumps(body, default=_plain).encode(),
                             headers={"Content-Type": JSON, "Accept": NPZ if npz_answer else JSON})
        return decode_answer(r)

    # -- robots ----------------------------------------------------------------------------------------------
    def health(self) -> dict[str, Any]:
        return self.request("GET", "/v1/health").json()

    def robots(self) -> list[dict[str, Any]]:
        return self.request("GET", "/v1/robots").json()["robots"]

    def upload(self, path_or_text: Union[str, bytes, os.PathLike], *, floating_base: bool = False,
               name: Optional[str] = None) -> "Robot":
        """Upload a URDF (a path, or the document as str/bytes); the same upload twice gives the same robot."""
        if isinstance(path_or_text, bytes):
            data = path_or_text
        elif isinstance(path_or_text, str) and path_or_text.lstrip().startswith("<"):
            data = path_or_text.encode("utf-8")
        else:
            data = Path(path_or_text).read_bytes()
        params: dict[str, Any] = {"floating_base": "true" if floating_base else "false"}
        if name:
            params["name"] = name
        r = self.request("POST", "/v1/robots", content=data, params=params,
                         headers={"Content-Type": "application/xml"})
        return Robot(self, r.json())

    def robot(self, id_or_name: str) -> "Robot":
        """A robot by id (bundled robots' ids are their names, e.g. 'planar-2r') or by unique name."""
        try:
            return Robot(self, self.request("GET", f"/v1/robots/{id_or_name}").json())
        except ServiceError as e:
            if e.status != 404:
                raise
        matches = [r for r in self.robots() if r["name"] == id_or_name]
        if len(matches) == 1:
            return Robot(self, self.request("GET", f"/v1/robots/{matches[0]['id']}").json())
        if not matches:
            raise ServiceError(404, f"robot: no robot with id or name {id_or_name!r}", "not_found", "robot")
        raise ServiceError(409, f"robot: {len(matches)} robots are named {id_or_name!r}; use an id: "
                                f"{[m['id'] for m in matches]}", "ambiguous", "robot")

    def delete(self, robot_id: str) -> None:
        self.request("DELETE", f"/v1/robots/{robot_id}")


class Robot:
    """One robot of the service; methods mirror ``dynamics`` (same names, shapes, keyword arguments)."""

    def __init__(self, client: Client, info: dict[str, Any]):
        self.client = client
        self.info = info
        self.id: str = info["id"]
        self.name: str = info["name"]
        self.nq: int = info["nq"]
        self.nv: int = info["nv"]
        self.joint_names: tuple[str, ...] = tuple(info["joint_names"])
        #: the ``scene`` of the last answer this object received (what was locked, pruned, skipped; nq and nv
        #: of the model that answered), None before the first call. One per object, not per thread.
        self.last_scene: Optional[dict[str, Any]] = None

    def __repr__(self) -> str:
        return f"Robot({self.id!r}, name={self.name!r}, nq={self.nq}, nv={self.nv})"

    def _call(self, op: str, payload: dict[str, Any], **kw: Any) -> dict[str, Any]:
        ans = self.client.call(f"/v1/robots/{self.id}/{op}", payload, **kw)
        self.last_scene = ans.pop("scene", None)
        return ans

    @staticmethod
    def _opt(x: Any) -> Any:
        return None if x is None else _as_array(x)

    @staticmethod
    def _locked(locked: Optional[Mapping[str, Any]]) -> Optional[dict[str, Any]]:
        return None if locked is None else _plain_tree(dict(locked))

    def inverse_dynamics(self, q, v, a, *, gravity=None, f_ext=None, locked=None) -> np.ndarray:
        return self._call("inverse-dynamics", {"q": _as_array(q), "v": _as_array(v), "a": _as_array(a),
                                               "gravity": self._opt(gravity), "f_ext": self._opt(f_ext),
                                               "locked": self._locked(locked)})["tau"]

    def forward_dynamics(self, q, v, tau, *, gravity=None, f_ext=None, locked=None) -> np.ndarray:
        return self._call("forward-dynamics", {"q": _as_array(q), "v": _as_array(v), "tau": _as_array(tau),
                                               "gravity": self._opt(gravity), "f_ext": self._opt(f_ext),
                                               "locked": self._locked(locked)})["a"]

    def mass_matrix(self, q, *, locked=None) -> np.ndarray:
        """(No gravity argument: M(q) does not depend on it, as in ``dynamics.mass_matrix``.)"""
        return self._call("mass-matrix", {"q": _as_array(q), "locked": self._locked(locked)})["mass_matrix"]

    def gravity_torques(self, q, *, gravity=None, locked=None) -> np.ndarray:
        return self._call("gravity-torques", {"q": _as_array(q), "gravity": self._opt(gravity),
                                              "locked": self._locked(locked)})["tau"]

    def bias_forces(self, q, v, *, gravity=None, locked=None) -> np.ndarray:
        return self._call("bias-forces", {"q": _as_array(q), "v": _as_array(v), "gravity": self._opt(gravity),
                                          "locked": self._locked(locked)})["tau"]

    def simulate(self, q0, v0, duration: float, *, torque: Optional[Mapping[str, Any]] = None,
                 integrator: Optional[str] = None, rtol: Optional[float] = None, atol: Optional[float] = None,
                 dt: Optional[float] = None, sample_dt: Optional[float] = None, gravity=None,
                 locked=None) -> Trajectory:
        """``torque``: {"type": "zero" | "constant" | "table" | "pd" | "computed_torque" | "operational_space", ...}
        (see the API docs)."""
        payload = {"q0": _as_array(q0), "v0": _as_array(v0), "duration": float(duration),
                   "torque": _plain_tree(torque) if torque is not None else None, "integrator": integrator,
                   "rtol": rtol, "atol": atol, "dt": dt, "sample_dt": sample_dt, "gravity": self._opt(gravity),
                   "locked": self._locked(locked)}
        ans = self._call("simulate", payload, npz_answer=True)
        report = ans.get("report", {})
        if isinstance(report, str):
            report = json.loads(report)
        return Trajectory(t=ans["t"], q=ans["q"], v=ans["v"], tau=ans["tau"], report=report)


def decode_answer(r: httpx.Response) -> dict[str, Any]:
    """A JSON or .npz answer -> dict of numpy arrays (numbers) and plain values (reports)."""
    kind = r.headers.get("content-type", "").split(";")[0].strip()
    if kind == NPZ:
        out: dict[str, Any] = {}
        with np.load(io.BytesIO(r.content), allow_pickle=False) as npz:
            for k in npz.files:
                a = npz[k]
                out[k] = json.loads(str(a)) if a.ndim == 0 and a.dtype.kind == "U" else a
        return out
    body = r.json()
    return {k: (np.asarray(v, dtype=np.float64) if isinstance(v, list) else v) for k, v in body.items()}


def _plain(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def _plain_tree(obj: Any) -> Any:
    """A torque spec with numpy arrays inside -> plain lists (it travels as JSON, also inside an .npz)."""
    if isinstance(obj, Mapping):
        return {k: _plain_tree(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain_tree(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return obj
