"""Python client of the dynamics service: the library's names and shapes, over HTTP.

    >>> from service.client import Client
    >>> with Client("http://127.0.0.1:8000") as client:
    ...     robot = client.robot("planar-2r")             # or client.upload("my_arm.urdf")
    ...     tau = robot.inverse_dynamics(q, v, a)         # numpy in, numpy out; (nq,) or (B, nq)
    ...     J = robot.frame_jacobian(q, "tip", reference="world")  # kinematics: the library's names too
    ...     traj = robot.simulate(q0, v0, 1.0, torque=dynamics.torques.PD(q_target, 50.0, 5.0))  # or a dict
    ...     tau1 = robot.inverse_dynamics(q[:1], v[:1], a[:1], locked={"joint2": 0.3})  # joint1 moves alone
    ...     robot.last_scene                    # {"locked": {"joint2": 0.3}, "skipped": [...], "nv": 1, ...}
    ...     job = client.submit("planar-2r", "inverse_dynamics", {"q": Q, "v": V, "a": A})  # a job: returns at once
    ...     job.wait(progress=True); tau = job.result()["tau"]
    ...     with robot.simulator(q0, v0, dt=0.01, integrator="rk4") as sim:   # stepped over a WebSocket
    ...         sim.step(tau); sim.q, sim.v, sim.t           # the library's Simulator, the state on the server

Batches of more than :data:`NPZ_THRESHOLD` numbers travel as ``.npz`` both ways (no JSON number formatting
or parsing); smaller requests use JSON. Every failure raises :class:`ServiceError` with the HTTP status, the
server's message (naming the field at fault) and its machine-readable code. A :class:`Simulator` holds one
session of ``/v1/sessions`` (a WebSocket; docs/guide/stepping.md has its protocol).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import socket
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import quote
from typing import Any, Mapping, Optional, Union

import httpx
import numpy as np
from tqdm.auto import tqdm

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
    """What ``Robot.simulate`` returns: sample times t (K,), q (K, nq), v (K, nv), tau (K, nv), the report, and
    lam (K, m), the constraint multipliers, when ``outputs`` has "lambda", and the sensitivities (K, 2 nv, ncol)
    when asked for (as ``dynamics.Trajectory``)."""
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    tau: np.ndarray
    report: dict = field(default_factory=dict)
    lam: Optional[np.ndarray] = None  # (K, m) constraint multipliers when outputs asked for "lambda"
    #: with contact outputs ["contacts"]: one row per active contact per sample, {"sample" (N,), "pair" (N,),
    #: "pairs" [(a, b)], "point" (N, 3), "normal" (N, 3), "normal_force" (N,), "friction" (N, 3), "depth" (N,),
    #: "slip" (N, 3)} (world frame; the service's form of ``dynamics.Trajectory.contacts``)
    contacts: Optional[dict] = None
    sensitivities: Optional[np.ndarray] = None  # (K, 2 nv, ncol) when simulate asked for sensitivities


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
        self.timeout = timeout
        self._key_header = {k: v for k, v in headers.items() if k == "Authorization"}  # (sessions' handshakes)
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
               name: Optional[str] = None, constraints: Optional[list[Any]] = None,
               mimic: Optional[str] = None) -> "Robot":
        """Upload a URDF (a path, or the document as str/bytes); the same upload twice gives the same robot.

        ``constraints``: ``dynamics.PointConstraint``, ``WeldConstraint``, ``RevoluteConstraint``,
        ``JointCoupling`` objects or their JSON form ({"type": "point", "frame_a": ...}); ``mimic``: "coupling"
        (default) or "independent"."""
        if isinstance(path_or_text, bytes):
            data = path_or_text
        elif isinstance(path_or_text, str) and path_or_text.lstrip().startswith("<"):
            data = path_or_text.encode("utf-8")
        else:
            data = Path(path_or_text).read_bytes()
        if constraints:
            body = {"urdf": data.decode("utf-8"), "floating_base": floating_base, "name": name, "mimic": mimic,
                    "constraints": [constraint_spec(c) for c in constraints]}
            return Robot(self, self.request("POST", "/v1/robots", json={k: v for k, v in body.items()
                                                                         if v is not None}).json())
        params: dict[str, Any] = {"floating_base": "true" if floating_base else "false"}
        if name:
            params["name"] = name
        if mimic:
            params["mimic"] = mimic
        r = self.request("POST", "/v1/robots", content=data, params=params,
                         headers={"Content-Type": "application/xml"})
        return Robot(self, r.json())

    def robot(self, id_or_name: str) -> "Robot":
        """A robot by id (bundled robots' ids are their names, e.g. 'planar_2r') or by unique name."""
        if not isinstance(id_or_name, str) or not id_or_name.strip():
            raise ValueError(f"robot: expected an id or a name (e.g. 'planar_2r'), got {id_or_name!r}")
        try:  # (quoted: a name holding '/' or '?' is a name, not a path)
            return Robot(self, self.request("GET", f"/v1/robots/{quote(id_or_name, safe='')}").json())
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

    # -- jobs ------------------------------------------------------------------------------------------------
    def submit(self, robot: Union[str, "Robot"], kind: str, inputs: Mapping[str, Any],
               options: Optional[Mapping[str, Any]] = None) -> "Job":
        """Queue a job (``kind``: simulate_many, inverse_dynamics, forward_dynamics, mass_matrix) and return at
        once. ``inputs``: arrays by name (q0, v0 and a torque: an object of ``dynamics.torques`` as
        ``robot.simulate`` takes, or a spec whose arrays may have one row per run; or q, v, a / q, v, tau / q);
        ``options``: duration and simulate's options, gravity, locked. Sent as .npz. The Job's ``wait()`` returns
        its final status, ``result()`` its arrays (for simulate_many: t, q, v, tau, counts, reports)."""
        robot_id = robot.id if isinstance(robot, Robot) else robot
        members: dict[str, Any] = {"robot": np.array(robot_id), "kind": np.array(kind),
                                   "options": np.array(json.dumps(_plain_tree(dict(options or {}))))}
        for name, value in inputs.items():
            if name == "torque" and value is not None:
                if not isinstance(value, Mapping):  # a torque object of dynamics.torques, as robot.simulate takes
                    value = torque_spec(value)
                spec = {k: v for k, v in value.items() if not isinstance(v, np.ndarray)}
                members["torque"] = np.array(json.dumps(_plain_tree(spec)))
                members.update({f"torque.{k}": v for k, v in value.items() if isinstance(v, np.ndarray)})
            elif value is not None:
                members[name] = _as_array(value)
        buf = io.BytesIO()
        np.savez(buf, **members)
        r = self.request("POST", "/v1/jobs", content=buf.getvalue(), headers={"Content-Type": NPZ})
        return Job(self, r.json())

    def job(self, job_id: str) -> "Job":
        return Job(self, self.request("GET", f"/v1/jobs/{job_id}").json())

    def jobs(self) -> list[dict[str, Any]]:
        return self.request("GET", "/v1/jobs").json()["jobs"]


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
        ans = self._send(f"/v1/robots/{self.id}/{op}", payload, kw)
        self.last_scene = ans.pop("scene", None)
        return ans

    def _send(self, path: str, payload: dict[str, Any], kw: dict[str, Any]) -> dict[str, Any]:
        """POST, and when the body is over the server's limit (413 on "body"), the batch in halves (each split
        again if need be), the answers stacked: a batch within DYNAMICS_MAX_BATCH is never refused for its bytes."""
        try:
            return self.client.call(path, payload, **kw)
        except ServiceError as e:
            halves = _halves(payload) if (e.status, e.field) == (413, "body") else None
            if halves is None:
                raise
        parts = [self._send(path, half, kw) for half in halves]
        return {k: (np.concatenate([p[k] for p in parts]) if isinstance(v, np.ndarray) and v.ndim else v)
                for k, v in parts[0].items()}

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

    def coriolis_matrix(self, q, v, *, locked=None) -> np.ndarray:
        return self._call("coriolis-matrix", {"q": _as_array(q), "v": _as_array(v),
                                              "locked": self._locked(locked)})["coriolis_matrix"]

    def kinetic_energy(self, q, v, *, locked=None):
        """A float, or (B,) for a batch."""
        return self._call("kinetic-energy", {"q": _as_array(q), "v": _as_array(v),
                                             "locked": self._locked(locked)})["kinetic_energy"]

    def potential_energy(self, q, *, gravity=None, locked=None):
        """A float, or (B,) for a batch."""
        return self._call("potential-energy", {"q": _as_array(q), "gravity": self._opt(gravity),
                                               "locked": self._locked(locked)})["potential_energy"]

    # -- derivatives -------------------------------------------------------------------------------------------
    def inverse_dynamics_derivatives(self, q, v, a, *, gravity=None, f_ext=None, locked=None) -> tuple:
        """(dtau_dq, dtau_dv, M), each (nv, nv) or (B, nv, nv): ``dynamics.inverse_dynamics_derivatives``."""
        ans = self._call("derivatives/inverse_dynamics", {"q": _as_array(q), "v": _as_array(v), "a": _as_array(a),
                                                          "gravity": self._opt(gravity), "f_ext": self._opt(f_ext),
                                                          "locked": self._locked(locked)})
        return ans["dtau_dq"], ans["dtau_dv"], ans["mass_matrix"]

    def forward_dynamics_derivatives(self, q, v, tau, *, gravity=None, f_ext=None, locked=None) -> tuple:
        """(da_dq, da_dv, M^-1), each (nv, nv) or (B, nv, nv): ``dynamics.forward_dynamics_derivatives``."""
        ans = self._call("derivatives/forward_dynamics", {"q": _as_array(q), "v": _as_array(v),
                                                          "tau": _as_array(tau), "gravity": self._opt(gravity),
                                                          "f_ext": self._opt(f_ext), "locked": self._locked(locked)})
        return ans["da_dq"], ans["da_dv"], ans["inverse_mass_matrix"]

    def constrained_forward_dynamics_derivatives(self, q, v, tau, *, baumgarte=None, gravity=None,
                                                 locked=None) -> tuple:
        """(da_dq, da_dv, da_dtau, dlam_dq, dlam_dv, dlam_dtau) as ``dynamics.constrained_forward_dynamics_derivatives``
        ((nv, nv) and (m, nv) blocks, a leading B for a batch)."""
        ans = self._call("derivatives/constrained_forward_dynamics", {
            "q": _as_array(q), "v": _as_array(v), "tau": _as_array(tau), "gravity": self._opt(gravity),
            "baumgarte": None if baumgarte is None else [float(x) for x in baumgarte],
            "locked": self._locked(locked)})
        return tuple(ans[k] for k in ("da_dq", "da_dv", "da_dtau", "dlambda_dq", "dlambda_dv", "dlambda_dtau"))

    # -- kinematics and task space ---------------------------------------------------------------------------
    @property
    def frame_names(self) -> tuple[str, ...]:
        """Every frame (URDF links and joints), in the order of forward_kinematics' answer."""
        if "frames" not in self.info:  # an upload's answer does not list them
            self.info = {**self.info, **self.client.request("GET", f"/v1/robots/{self.id}").json()}
        return tuple(f["name"] for f in self.info["frames"])

    def forward_kinematics(self, q, *, frames=None, locked=None) -> np.ndarray:
        """World placements (nframes, 4, 4) or (B, nframes, 4, 4): every frame (``frame_names`` order) or those of
        ``frames``, in that order."""
        return self._call("kinematics", {"q": _as_array(q), "frames": None if frames is None else list(frames),
                                         "locked": self._locked(locked)})["placements"]

    def frame_placement(self, q, frame: str, *, locked=None) -> np.ndarray:
        """World placement (4, 4) of one frame, (B, 4, 4) for a batch."""
        return self.forward_kinematics(q, frames=[frame], locked=locked)[..., 0, :, :]

    def frame_jacobian(self, q, frame, *, reference: str = "local_world_aligned", point=None,
                       locked=None) -> np.ndarray:
        return self._call("jacobian", {"q": _as_array(q), "frame": frame, "reference": reference,
                                       "point": self._opt(point), "locked": self._locked(locked)})["jacobian"]

    def center_of_mass(self, q, *, locked=None) -> np.ndarray:
        return self._call("center-of-mass", {"q": _as_array(q), "locked": self._locked(locked)})["center_of_mass"]

    def center_of_mass_velocity(self, q, v, *, locked=None) -> np.ndarray:
        return self._call("center-of-mass", {"q": _as_array(q), "v": _as_array(v),
                                             "locked": self._locked(locked)})["center_of_mass_velocity"]

    def com_jacobian(self, q, *, locked=None) -> np.ndarray:
        return self._call("center-of-mass", {"q": _as_array(q), "locked": self._locked(locked)})["com_jacobian"]

    def inverse_mass_matrix(self, q, *, locked=None) -> np.ndarray:
        return self._call("inverse-mass-matrix", {"q": _as_array(q),
                                                  "locked": self._locked(locked)})["inverse_mass_matrix"]

    def operational_space_inertia(self, q, frame, *, reference: str = "local_world_aligned", rows=None,
                                  damping: float = 0.0, locked=None) -> np.ndarray:
        """``rows``: None (all 6), a slice (``slice(0, 3)``: position only) or indices of [linear; angular]."""
        if isinstance(rows, slice):
            rows = list(range(6))[rows]
        return self._call("operational-space-inertia", {
            "q": _as_array(q), "frame": frame, "reference": reference,
            "rows": None if rows is None else [int(r) for r in rows], "damping": float(damping),
            "locked": self._locked(locked)})["operational_space_inertia"]

    def inverse_kinematics(self, frame, target, q0, *, position_only: bool = False, tol: Optional[float] = None,
                           max_iter: Optional[int] = None, damping: Optional[float] = None,
                           respect_limits: bool = False, locked=None) -> tuple[np.ndarray, dict[str, Any]]:
        """(q, report) as ``dynamics.inverse_kinematics``: the report's values are numbers, or arrays of B."""
        ans = self._call("inverse-kinematics", {
            "frame": frame, "target": _as_array(target), "q0": _as_array(q0), "position_only": position_only,
            "tol": tol, "max_iter": max_iter, "damping": damping, "respect_limits": respect_limits,
            "locked": self._locked(locked)})
        report = ans["report"]
        if isinstance(report, str):
            report = json.loads(report)
        return ans["q"], {k: (np.asarray(v) if isinstance(v, list) else v) for k, v in report.items()}

    # -- closed loops and coupled joints -----------------------------------------------------------------------
    def constraint_residual(self, q, *, locked=None) -> np.ndarray:
        """phi(q): (m,) or (B, m), as ``dynamics.constraint_residual``."""
        return self._call("constraint-residual", {"q": _as_array(q), "locked": self._locked(locked)})["residual"]

    def assemble(self, q_guess, *, fixed=None, tol: Optional[float] = None, max_iter: Optional[int] = None,
                 locked=None) -> np.ndarray:
        """``fixed``: joint names kept at their value in q_guess, or a mapping joint name -> value."""
        fixed = None if fixed is None else (_plain_tree(dict(fixed)) if isinstance(fixed, Mapping) else list(fixed))
        return self._call("assemble", {"q_guess": _as_array(q_guess), "fixed": fixed, "tol": tol,
                                       "max_iter": max_iter, "locked": self._locked(locked)})["q"]

    def constrained_forward_dynamics(self, q, v, tau, *, baumgarte=None, gravity=None,
                                     locked=None) -> tuple[np.ndarray, np.ndarray]:
        """(a, lam) as ``dynamics.constrained_forward_dynamics``."""
        ans = self._call("constrained-forward-dynamics", {
            "q": _as_array(q), "v": _as_array(v), "tau": _as_array(tau), "gravity": self._opt(gravity),
            "baumgarte": None if baumgarte is None else [float(x) for x in baumgarte],
            "locked": self._locked(locked)})
        return ans["a"], ans["lambda"]

    def constrained_inverse_dynamics(self, q, v, a, *, actuated, gravity=None, locked=None) -> np.ndarray:
        return self._call("constrained-inverse-dynamics", {
            "q": _as_array(q), "v": _as_array(v), "a": _as_array(a), "actuated": list(actuated),
            "gravity": self._opt(gravity), "locked": self._locked(locked)})["tau"]

    def simulate(self, q0, v0, duration: float, *, torque: Any = None,
                 integrator: Optional[str] = None, rtol: Optional[float] = None, atol: Optional[float] = None,
                 dt: Optional[float] = None, sample_dt: Optional[float] = None, gravity=None,
                 locked=None, outputs=None, baumgarte=None, project: Optional[bool] = None,
                 contact: Any = None, sensitivities=None) -> Trajectory:
        """``torque``: what ``dynamics.simulate`` takes (``dynamics.torques.PD``, ``Table``, ``ComputedTorque``,
        ``OperationalSpace``, a constant tau, None) or the HTTP form {"type": "zero" | "constant" | "table" | "pd" |
        "computed_torque" | "operational_space", ...} (see the API docs). ``contact``: a ``dynamics.Contact`` or
        its HTTP form {"ground": ..., "friction": ..., "objects": [...], ...}.  ``sensitivities``: True or names,
        as ``dynamics.simulate`` takes them."""
        payload = {"q0": _as_array(q0), "v0": _as_array(v0), "duration": float(duration),
                   "torque": torque_spec(torque), "integrator": integrator,
                   "rtol": rtol, "atol": atol, "dt": dt, "sample_dt": sample_dt, "gravity": self._opt(gravity),
                   "locked": self._locked(locked), "outputs": None if outputs is None else list(outputs),
                   "baumgarte": self._opt(baumgarte), "project": project, "contact": contact_spec(contact),
                   "sensitivities": sensitivities if sensitivities in (None, True, False) else list(sensitivities)}
        ans = self._call("simulate", payload, npz_answer=True)
        report = ans.get("report", {})
        if isinstance(report, str):
            report = json.loads(report)
        return Trajectory(t=ans["t"], q=ans["q"], v=ans["v"], tau=ans["tau"], report=report, lam=ans.get("lambda"),
                          contacts=contact_rows(ans), sensitivities=ans.get("sensitivities"))

    def simulator(self, q0, v0, *, dt: float, torque: Any = None, contact: Any = None,
                  integrator: Optional[str] = None, substep: Optional[float] = None, rtol: Optional[float] = None,
                  atol: Optional[float] = None, gravity=None, limits: Optional[str] = None,
                  limit_stiffness: Optional[float] = None, limit_damping: Optional[float] = None,
                  friction_eps: Optional[float] = None, baumgarte=None, project: Optional[bool] = None,
                  n: Optional[int] = None, locked=None) -> "Simulator":
        """A ``dynamics.Simulator`` of this robot held by the service, stepped over a WebSocket (``/v1/sessions``):
        the library's arguments (``torque`` and ``contact`` as :meth:`simulate` takes them), plus ``n`` (n
        environments from one q0) and ``locked``. Close it (or use ``with``) to free it on the server."""
        create = {"type": "create", "robot": self.id, "q0": _as_array(q0), "v0": _as_array(v0), "dt": float(dt),
                  "torque": torque_spec(torque), "contact": contact_spec(contact), "integrator": integrator,
                  "substep": substep, "rtol": rtol, "atol": atol, "gravity": self._opt(gravity), "limits": limits,
                  "limit_stiffness": limit_stiffness, "limit_damping": limit_damping, "friction_eps": friction_eps,
                  "baumgarte": self._opt(baumgarte), "project": project, "n": n, "locked": self._locked(locked)}
        return Simulator(self.client, {k: v for k, v in create.items() if v is not None})


def contact_rows(ans: Mapping[str, Any]) -> Optional[dict[str, Any]]:
    """An answer's ``contacts.<field>`` members -> {field: array}, ``pairs`` as [(a, b)] (None without them)."""
    contacts = {k.split(".", 1)[1]: v for k, v in ans.items() if k.startswith("contacts.")} or None
    if contacts is not None:
        pairs = contacts.get("pairs")
        contacts["pairs"] = [tuple(p) for p in (json.loads(pairs) if isinstance(pairs, str) else pairs or [])]
    return contacts


def contacts_per_run(ans: Mapping[str, Any]) -> Optional[list[dict[str, Any]]]:
    """A simulate_many job's result with contact outputs -> one dict per run, as ``Robot.simulate`` returns a
    run's ``contacts`` (sample, pair, pairs, point, normal, normal_force, friction, depth, slip): the rows of
    ``contacts.run`` == k, views into the result's arrays. None without contact outputs."""
    rows = contact_rows(ans)
    if rows is None:
        return None
    run = np.asarray(rows.pop("run")).astype(np.int64)
    ends = np.searchsorted(run, np.arange(len(ans["counts"]) + 1))  # (rows are in run order)
    return [{k: (v if k == "pairs" else v[a:b]) for k, v in rows.items()} for a, b in zip(ends[:-1], ends[1:])]


#: the library's torque classes (dynamics.torques) the service knows: class name -> (HTTP type, attributes sent)
TORQUE_CLASSES: dict[str, tuple[str, tuple[str, ...]]] = {
    "PD": ("pd", ("q_target", "kp", "kd", "v_target", "tau_ff")),
    "Table": ("table", ("t", "tau", "hold")),
    "ComputedTorque": ("computed_torque", ("t", "q", "v", "a", "kp", "kd")),
    "OperationalSpace": ("operational_space", ("frame", "reference", "kp", "kd", "posture", "posture_kp",
                                               "posture_kd", "rows", "damping")),
    "Target": ("operational_space", ("frame", "position", "orientation", "kp", "kd", "posture", "posture_kp",
                                     "posture_kd", "rows", "damping")),
}

#: objects nested in a torque object, sent as the mapping of their attributes (dynamics.torques.TaskReference)
NESTED_CLASSES: dict[str, tuple[str, ...]] = {
    "TaskReference": ("t", "position", "velocity", "acceleration", "orientation"),
}


#: the arguments a batch is split along (axis 0) when its body is too large, with their ndim when batched
BATCHED = {"q": 2, "v": 2, "a": 2, "tau": 2, "f_ext": 3}


def _halves(payload: Mapping[str, Any]) -> Optional[list[dict[str, Any]]]:
    """``payload``'s batch cut in two along its states, None when it holds fewer than two states."""
    sizes = {v.shape[0] for k, v in payload.items() if isinstance(v, np.ndarray) and v.ndim == BATCHED.get(k)}
    if len(sizes) != 1 or (size := sizes.pop()) < 2:
        return None
    cut = size // 2

    def part(sl: slice) -> dict[str, Any]:
        return {k: (v[sl] if isinstance(v, np.ndarray) and v.ndim == BATCHED.get(k) else v) for k, v in payload.items()}

    return [part(slice(0, cut)), part(slice(cut, None))]


def torque_spec(torque: Any) -> Optional[dict[str, Any]]:
    """The ``torque=`` of ``dynamics.simulate`` (a torque object of ``dynamics.torques``, a constant tau, None) or
    an HTTP spec (a mapping) -> the HTTP spec, plain lists inside. The library is not imported for this: an
    object of it can only exist once the caller imported it."""
    if torque is None or isinstance(torque, Mapping):
        return None if torque is None else _plain_tree(dict(torque))
    torques = sys.modules.get("dynamics.torques")
    cls = type(torque)
    if torques is not None and getattr(torques, cls.__name__, None) is cls and cls.__name__ in TORQUE_CLASSES:
        kind, attributes = TORQUE_CLASSES[cls.__name__]
        spec = {name: getattr(torque, name) for name in attributes if getattr(torque, name) is not None}
        return _plain_tree({"type": kind, **spec})
    if isinstance(torque, (list, tuple, np.ndarray)):
        return {"type": "constant", "tau": _plain_tree(torque)}
    raise TypeError(f"torque: expected a dynamics.torques object ({', '.join(TORQUE_CLASSES)}), a constant tau, None "
                    f"or a mapping {{'type': ...}}, got {cls.__name__}")
class Job:
    """A job of the service: ``status()``, ``wait(progress=True)``, ``result()``, ``cancel()``."""

    FINAL = ("done", "failed", "cancelled")

    def __init__(self, client: Client, info: dict[str, Any]):
        self.client = client
        self.id: str = info["id"]
        self.info = info

    def __repr__(self) -> str:
        return f"Job({self.id!r}, {self.info['kind']}, {self.info['status']})"

    def status(self) -> dict[str, Any]:
        """The job's record: status, progress {done, total, fraction}, timing, error, ..."""
        self.info = self.client.request("GET", f"/v1/jobs/{self.id}").json()
        return self.info

    def wait(self, progress: bool = False, timeout: Optional[float] = None, poll: float = 0.5) -> dict[str, Any]:
        """Poll until the job is done, failed or cancelled (a tqdm bar of its items with ``progress``); its
        final status record, not the arrays: :meth:`result` fetches those (``job.wait(); out = job.result()``).
        ``timeout`` seconds: a ServiceError (code "timeout") if it is still running then."""
        end = None if timeout is None else time.monotonic() + timeout
        bar = None
        try:
            while True:
                info = self.status()
                if progress:
                    if bar is None:
                        bar = tqdm(total=info["progress"]["total"], desc=info["kind"], unit="item")
                    bar.update(info["progress"]["done"] - bar.n)
                if info["status"] in self.FINAL:
                    return info
                if end is not None and time.monotonic() > end:
                    raise ServiceError(0, f"job {self.id}: still {info['status']} after {timeout} s", "timeout")
                time.sleep(poll)
        finally:
            if bar is not None:
                bar.close()

    def result(self) -> dict[str, Any]:
        """The result as arrays (tau / a / mass_matrix; or t, q, v, tau, counts and reports of simulate_many);
        a ServiceError 409 until it is done. A simulate_many whose contact asked for ``outputs=["contacts"]``
        also has ``contacts``: one dict per run, as :class:`Trajectory`'s ``contacts`` (``contacts[k]["sample"]``,
        ``["normal_force"]``, ...), beside the flat rows of every run (``contacts.run``, ``contacts.sample``, ...)."""
        out = decode_answer(self.client.request("GET", f"/v1/jobs/{self.id}/result", headers={"Accept": NPZ}))
        per_run = contacts_per_run(out) if "contacts.run" in out else None
        return out if per_run is None else {**out, "contacts": per_run}

    def cancel(self) -> dict[str, Any]:
        """Cancel it if it is queued or running; remove it (and its result) if it has finished."""
        return self.client.request("DELETE", f"/v1/jobs/{self.id}").json()


class SimulationWarning(UserWarning):
    """A period of a :class:`Simulator` failed on the server (as ``dynamics.SimulationWarning`` in the library):
    the environment is marked (``failed``) and waits for ``reset`` or ``set_state``."""


class Simulator:
    """``dynamics.Simulator`` held by the service, stepped over one WebSocket (``Robot.simulator`` makes it).

    The library's loop and names: ``step(tau)``, ``t``, ``q``, ``v`` (read-only arrays of the last answer, no
    round trip), ``failed``, ``reset``, ``state``, ``set_state``, ``status``, ``error``, ``stats``,
    ``contact_forces``; one environment or ``n``. Every call is one message and its answer (docs/guide/stepping.md
    has the protocol); a refusal raises :class:`ServiceError` with the status, message and field the HTTP API
    would give, and the session goes on. ``close()`` (or ``with``) frees the simulator on the server; so does a
    dropped connection, and the server's idle timeout.
    """

    def __init__(self, client: Client, create: dict[str, Any]):
        from websockets.sync.client import connect  # (only sessions need the package)
        url = ("wss://" if client.base_url.startswith("https://") else "ws://") + \
            client.base_url.split("://", 1)[1] + "/v1/sessions"
        self.timeout = client.timeout
        self._stack = contextlib.ExitStack()
        try:
            # no compression (torques and states do not compress; deflating them costs more than sending them)
            self._ws = self._stack.enter_context(connect(url, additional_headers=client._key_header,
                                                         compression=None, max_size=None,
                                                         open_timeout=client.timeout, close_timeout=5.0))
        except OSError as e:
            raise ServiceError(0, f"cannot reach {client.base_url}: {e}", "unreachable") from None
        except Exception as e:  # websockets' InvalidHandshake: not a WebSocket server, a proxy's refusal
            raise ServiceError(0, f"{url}: the WebSocket handshake failed: {e}", "handshake") from None
        with contextlib.suppress(OSError):  # one small frame each way per step: do not let Nagle hold it
            self._ws.socket.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        try:
            self.info: dict[str, Any] = self._call(json.dumps(create, default=_plain))
            self.session: str = self.info["session"]
            self.n: int = self.info["n"]
            self.nq: int = self.info["nq"]
            self.nv: int = self.info["nv"]
            self.dt: float = self.info["dt"]
            self.batched: bool = self.info["batched"]
            self.joint_names: tuple[str, ...] = tuple(self.info["joint_names"])
            self._failed = np.zeros(self.n, dtype=bool)
            self._read_state(self._call('{"type":"state"}', binary=True))
        except BaseException:
            self._stack.close()
            raise

    def __repr__(self) -> str:
        what = f"{self.n} environments" if self.batched else f"t={self.t:.6g}"
        return f"<service.client.Simulator {self.info['robot']!r} {self.info['integrator']} dt={self.dt:g} {what}>"

    def __enter__(self) -> "Simulator":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # -- the loop ------------------------------------------------------------------------------------------------
    def step(self, tau=None) -> None:
        """One period ``dt`` under ``tau`` held over it (added to the torque source's): None (zero), (nv,) (every
        environment) or (n, nv)."""
        frame = b"" if tau is None else self._torque(tau)
        before = self._failed
        self._answer(self._call(frame, binary=True))
        fresh = np.flatnonzero(self._failed & ~before)
        if fresh.size:
            status = self.status
            for i in fresh[:5]:
                why = status[i] if self.batched else status
                warnings.warn(f"{'environment ' + str(i) + ': ' if self.batched else ''}a period failed on the "
                              f"server ({why}); reset() or set_state() to go on", SimulationWarning, stacklevel=2)

    def _torque(self, tau: Any) -> bytes:
        x = np.asarray(tau, dtype=np.float64)
        if x.shape != (self.nv,) and not (self.batched and x.shape == (self.n, self.nv)):
            want = f"({self.nv},)" + (f" or ({self.n}, {self.nv})" if self.batched else "")
            raise ValueError(f"tau: expected shape {want}, got {x.shape}")
        return np.ascontiguousarray(x, dtype="<f8").tobytes()

    def reset(self, q=None, v=None, *, which=None, t: float = 0.0) -> None:
        """Start environments again from (q, v) at t (the initial states when None); ``which``: indices or a
        boolean mask (then q, v have a row per chosen environment, or one row for all)."""
        self._answer(self._call(self._message("reset", q=q, v=v, which=which, t=float(t)), binary=True))

    def state(self) -> np.ndarray:
        """The full state, as the library's: (n, 1 + nq + nv + 4) rows, or one row for a single environment."""
        x = np.frombuffer(self._call('{"type":"state"}', binary=True), dtype="<f8").reshape(self.n, -1).copy()
        return x if self.batched else x[0]

    def set_state(self, x, *, which=None) -> None:
        """Go back to a state :meth:`state` returned (rows for the environments ``which``)."""
        self._answer(self._call(self._message("set_state", x=x, which=which), binary=True))

    # -- what the loop reads -----------------------------------------------------------------------------------
    @property
    def t(self):
        """Time (s): a float, or (n,) per environment (of the last answer: no round trip)."""
        return self._t if self.batched else float(self._t[0])

    @property
    def q(self) -> np.ndarray:
        """(nq,) or (n, nq), read-only."""
        return self._q if self.batched else self._q[0]

    @property
    def v(self) -> np.ndarray:
        """(nv,) or (n, nv), read-only."""
        return self._v if self.batched else self._v[0]

    @property
    def failed(self):
        """Whether an environment's last period failed (it waits for reset or set_state): bool or (n,)."""
        return self._failed.copy() if self.batched else bool(self._failed[0])

    def _status(self) -> dict[str, Any]:
        return self._call('{"type":"status"}')

    @property
    def status(self):
        """"ok", or why the last period failed: a str, or a list of n (one round trip)."""
        status = self._status()["status"]
        return status if self.batched else status[0]

    @property
    def error(self):
        """The last period's error estimate (NaN for the fixed-step methods): a float or (n,) (one round trip)."""
        e = np.array([np.nan if x is None else x for x in self._status()["error_estimate"]])
        return e if self.batched else float(e[0])

    @property
    def stats(self) -> dict[str, Any]:
        """Steps, rejected steps, right-hand sides, Jacobians and the server's wall time in step() (one round trip)."""
        return self._status()["stats"]

    def contact_forces(self, env: Optional[int] = None, *, details: bool = False):
        """f_ext (nbodies, 6) of environment ``env`` at the present state, or (f_ext, details: a dict of arrays)
        with ``details``, as the library's."""
        ans = self._call(self._message("contact_forces", env=env, details=details))
        f_ext = np.asarray(ans["f_ext"], dtype=np.float64)
        if not details:
            return f_ext
        more = {k: (v if k == "pairs" or not isinstance(v, list) else np.asarray(v, dtype=np.float64))
                for k, v in ans["details"].items()}
        return f_ext, more

    def close(self) -> None:
        """End the session (the server frees its simulator); idempotent."""
        if self._ws is None:
            return
        try:
            with contextlib.suppress(Exception):
                self._ws.send('{"type":"close"}')
                self._ws.recv(timeout=5.0)
        finally:
            self._ws = None
            self._stack.close()

    # -- plumbing ----------------------------------------------------------------------------------------------
    @staticmethod
    def _message(kind: str, **fields: Any) -> str:
        return json.dumps({"type": kind, **{k: (v.tolist() if isinstance(v, np.ndarray) else v)
                                            for k, v in fields.items() if v is not None}}, default=_plain)

    def _call(self, message: Union[str, bytes], *, binary: bool = False) -> Any:
        """Send one message, return its answer: bytes when ``binary``, else the decoded JSON; an error frame
        raises ServiceError."""
        from websockets.exceptions import ConnectionClosed
        if self._ws is None:
            raise ServiceError(0, "session: closed; make another with robot.simulator(...)", "closed")
        try:
            self._ws.send(message)
            answer = self._ws.recv(timeout=self.timeout)
        except TimeoutError:
            self.close()  # (an answer still on its way would answer the next message)
            raise ServiceError(0, f"session: no answer in {self.timeout} s; the session is closed", "timeout") \
                from None
        except ConnectionClosed as e:
            self._ws = None
            self._stack.close()
            raise ServiceError(0, f"session: the connection closed (code {e.rcvd.code if e.rcvd else 1006}"
                                  f"{': ' + e.rcvd.reason if e.rcvd and e.rcvd.reason else ''})", "closed") from None
        if isinstance(answer, bytes):
            if binary:
                return answer
            raise ServiceError(0, "session: a binary answer to a JSON message", "protocol")
        body = json.loads(answer)
        if "error" in body:
            if body.get("status") in (408, 429) or str(body.get("error")) == "internal_error":
                self.close()
            raise ServiceError(int(body.get("status", 0)), str(body.get("detail")), str(body["error"]),
                               body.get("field"))
        if binary:
            raise ServiceError(0, f"session: a JSON answer where data was expected: {answer[:200]}", "protocol")
        return body

    def _answer(self, frame: bytes) -> None:
        """[t (n), q (n, nq), v (n, nv), failed (n)] float64 -> read-only views."""
        n, nq, nv = self.n, self.nq, self.nv
        a = np.frombuffer(frame, dtype="<f8")
        if a.size != n * (2 + nq + nv):
            raise ServiceError(0, f"session: an answer of {a.size} numbers, expected {n * (2 + nq + nv)}", "protocol")
        self._t, self._q = a[:n], a[n:n + n * nq].reshape(n, nq)
        self._v, self._failed = a[n + n * nq:n * (1 + nq + nv)].reshape(n, nv), a[n * (1 + nq + nv):] != 0

    def _read_state(self, frame: bytes) -> None:
        x = np.frombuffer(frame, dtype="<f8").reshape(self.n, -1)
        nq, nv = self.nq, self.nv
        self._t, self._q, self._v = x[:, 0], x[:, 1:1 + nq], x[:, 1 + nq:1 + nq + nv]


#: the library's constraint classes (dynamics.constraints) -> their HTTP type
CONSTRAINT_TYPES = {"PointConstraint": "point", "WeldConstraint": "weld", "RevoluteConstraint": "revolute",
                    "JointCoupling": "coupling"}


def constraint_spec(c: Any) -> dict[str, Any]:
    """A constraint declaration of the library (read by its attributes: no import of ``dynamics``) or its HTTP
    form -> the HTTP form."""
    if isinstance(c, Mapping):
        return _plain_tree(dict(c))
    kind = CONSTRAINT_TYPES.get(type(c).__name__)
    if kind is None:
        raise TypeError(f"constraints: expected dynamics constraint declarations or dicts, got {type(c).__name__}")
    out = {k: _plain_tree(v) for k, v in vars(c).items() if v is not None and not (k == "name" and not v)}
    return {"type": kind, **out}


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
    return {k: (_numbers(v) if isinstance(v, list) else v) for k, v in r.json().items()}


def _numbers(v: list) -> Any:
    """A JSON list of numbers -> a float64 array; a list of names (frames) stays a list."""
    a = np.asarray(v)
    return a.astype(np.float64) if a.dtype.kind in "fiub" else v


def _plain(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


#: the library's contact declarations (dynamics.Sphere, ...) -> (HTTP type, attributes sent besides frame, name)
CONTACT_CLASSES: dict[str, tuple[str, tuple[str, ...]]] = {
    "Sphere": ("sphere", ("radius", "offset")), "Box": ("box", ("size", "pose")),
    "Capsule": ("capsule", ("radius", "length", "pose")), "Cylinder": ("cylinder", ("radius", "length", "pose")),
    "ContactPoint": ("point", ("point",)), "HalfSpace": ("half_space", ("normal", "offset")),
}
_MATERIAL_FIELDS = ("stiffness", "dissipation", "mu_static", "mu_dynamic", "stiction_velocity",
                    "penetration_allowance")


def contact_spec(contact: Any) -> Optional[dict[str, Any]]:
    """A ``dynamics.Contact`` or an HTTP contact spec (a mapping) -> the HTTP spec, plain lists inside. The
    library is not imported for this (its objects are read by their class names and attributes)."""
    if contact is None or isinstance(contact, Mapping):
        return None if contact is None else _plain_tree(dict(contact))
    if type(contact).__name__ != "Contact":
        raise TypeError(f"contact: expected a dynamics.Contact or a mapping, got {type(contact).__name__}")
    ground = contact.ground
    spec: dict[str, Any] = {
        "ground": False if ground is None else {"normal": list(ground.normal), "height": ground.height},
        "friction": _material_spec(contact.friction),
        "objects": [_geometry_spec(g) for g in contact.objects],
        "materials": {name: _material_spec(m) for name, m in contact.materials.items()},
        "self_collision": bool(contact.self_collision),
        "exclude": [list(p) for p in contact.exclude], "outputs": list(contact.outputs)}
    if contact.geometries is not None:
        spec["geometries"] = [_geometry_spec(g) for g in contact.geometries]
    if contact.pairs is not None:
        spec["pairs"] = [list(p) for p in contact.pairs]
    return _plain_tree(spec)


def _geometry_spec(g: Any) -> dict[str, Any]:
    kind, attributes = CONTACT_CLASSES.get(type(g).__name__, (None, ()))
    if kind is None:
        raise TypeError(f"contact: expected dynamics.Sphere, Box, Capsule, Cylinder, ContactPoint or HalfSpace, got "
                        f"{type(g).__name__}")
    spec = {"type": kind, **{name: getattr(g, name) for name in attributes}}
    if hasattr(g, "frame"):
        spec["frame"] = g.frame
    if g.name is not None:
        spec["name"] = g.name
    return spec


def _material_spec(m: Any) -> Any:
    if isinstance(m, (int, float)):
        return m
    return {name: getattr(m, name) for name in _MATERIAL_FIELDS if getattr(m, name) is not None}


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
    if type(obj).__name__ in NESTED_CLASSES:
        return {k: _plain_tree(getattr(obj, k)) for k in NESTED_CLASSES[type(obj).__name__]
                if getattr(obj, k) is not None}
    return obj
