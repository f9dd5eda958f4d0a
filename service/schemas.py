"""Request and answer schemas of the HTTP API, in one place.

State arguments are typed :data:`Array`: one state (a list of nq or nv numbers) or a batch (a list of such
lists); they are turned into float64 arrays in one ``np.asarray`` call, never walked in Python, and the
shape check against the robot is the library's (its messages name the argument and the expected shape).
Unknown fields are refused (``extra="forbid"``) so that a typo is a 422, not a silently ignored option; new
optional fields (issue 5's ``locked``; a ``scene`` object in answers) are added without breaking a caller.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, Optional, Union

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationInfo, WithJsonSchema

from .codec import to_array

_NUMBERS = {"type": "array", "items": {"type": "number"}}
_STATE_SCHEMA = {"anyOf": [_NUMBERS, {"type": "array", "items": _NUMBERS}],
                 "description": "one state (list of numbers) or a batch (list of equal-length lists)"}


def _array(value: Any, info: ValidationInfo) -> np.ndarray:
    return to_array(value, info.field_name or "value")


def _array3(value: Any, info: ValidationInfo) -> np.ndarray:
    return to_array(value, info.field_name or "value", max_ndim=3)


def _vec3(value: Any, info: ValidationInfo) -> np.ndarray:
    from .errors import bad_input

    arr = to_array(value, info.field_name or "value", max_ndim=1)
    if arr.shape != (3,):
        raise bad_input(f"{info.field_name}: expected shape (3,), got {arr.shape}", info.field_name)
    return arr


def _gains(value: Any, info: ValidationInfo) -> np.ndarray:
    return to_array(value, info.field_name or "value", max_ndim=1)


Array = Annotated[Any, BeforeValidator(_array), WithJsonSchema(_STATE_SCHEMA)]
Array3 = Annotated[Any, BeforeValidator(_array3), WithJsonSchema(
    {"type": "array", "description": "(nbodies, 6) or (B, nbodies, 6): [force, torque] per body, body frame"})]
Vec3 = Annotated[Any, BeforeValidator(_vec3), WithJsonSchema(
    {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3})]
Gains = Annotated[Any, BeforeValidator(_gains), WithJsonSchema(
    {"anyOf": [{"type": "number"}, _NUMBERS], "description": "a number, or one per velocity coordinate"})]


class _Request(BaseModel):
    model_config = ConfigDict(extra="forbid", arbitrary_types_allowed=True)


class _Dynamics(_Request):
    # Issue 5 adds here: locked: Optional[dict[str, float]] = None  (the model cache is already keyed for it)
    gravity: Optional[Vec3] = Field(None, description="world-frame gravity, default (0, 0, -9.81)")


class InverseDynamicsRequest(_Dynamics):
    q: Array
    v: Array
    a: Array
    f_ext: Optional[Array3] = None


class ForwardDynamicsRequest(_Dynamics):
    q: Array
    v: Array
    tau: Array
    f_ext: Optional[Array3] = None


class MassMatrixRequest(_Request):
    q: Array


class GravityTorquesRequest(_Dynamics):
    q: Array


class BiasForcesRequest(_Dynamics):
    q: Array
    v: Array


# -- simulation torques: a tagged union on "type" ---------------------------------------------------------------
class ZeroTorque(_Request):
    type: Literal["zero"]


class ConstantTorque(_Request):
    type: Literal["constant"]
    tau: Array


class TableTorque(_Request):
    """Torques tabulated at times ``t`` (N,), rows ``tau`` (N, nv); "linear" interpolation or "zoh" hold."""
    type: Literal["table"]
    t: Array
    tau: Array
    hold: Literal["linear", "zoh"] = "linear"


class PDTorque(_Request):
    """tau = kp (q_target - q) + kd (v_target - v) + tau_ff (dynamics.torques.PD)."""
    type: Literal["pd"]
    q_target: Array
    kp: Gains
    kd: Gains
    v_target: Optional[Array] = None
    tau_ff: Optional[Array] = None


class ComputedTorque(_Request):
    """tau = M(q) (a_ref + kd (v_ref - v) + kp (q_ref - q)) + h(q, v), tracking the reference samples
    (t (N,), q (N, nq), v (N, nv), a (N, nv)) interpolated by quintic Hermite (dynamics.torques.ComputedTorque)."""
    type: Literal["computed_torque"]
    t: Array
    q: Array
    v: Array
    a: Array
    kp: Gains
    kd: Gains


TorqueSpec = Annotated[Union[ZeroTorque, ConstantTorque, TableTorque, PDTorque, ComputedTorque],
                       Field(discriminator="type")]


class SimulateRequest(_Request):
    # Issue 5 adds here: locked: Optional[dict[str, float]] = None
    q0: Array
    v0: Array
    duration: float = Field(gt=0, description="seconds of simulated time")
    torque: Optional[TorqueSpec] = None
    integrator: Optional[Literal["euler", "rk4", "rk45", "radau", "auto"]] = Field(
        None, description="default 'auto' (adaptive, switches to radau when stiff); euler and rk4 need dt")
    rtol: Optional[float] = Field(None, gt=0, description="adaptive methods, default 1e-6")
    atol: Optional[float] = Field(None, ge=0, description="adaptive methods, default 1e-8")
    dt: Optional[float] = Field(None, gt=0, description="step of fixed-step integrators (first step otherwise), s")
    sample_dt: Optional[float] = Field(None, gt=0, description="spacing of the returned samples, seconds")
    gravity: Optional[Vec3] = None
    limits: Optional[Literal["spring"]] = Field(None, description="spring-damper at the URDF position limits")
    limit_stiffness: Optional[float] = Field(None, ge=0)
    limit_damping: Optional[float] = Field(None, ge=0)
    friction_eps: Optional[float] = Field(None, gt=0)
    error_estimate: Optional[Literal["rerun", "local", "none"]] = Field(
        None, description="how report.error_estimate is measured; 'rerun' (default) costs a second run")


#: the SimulateRequest fields passed on to dynamics.simulate as keyword arguments (None = library default)
SIMULATE_OPTIONS = ("integrator", "rtol", "atol", "dt", "sample_dt", "gravity", "limits", "limit_stiffness",
                    "limit_damping", "friction_eps", "error_estimate")


class UploadRequest(_Request):
    urdf: str = Field(description="the URDF document")
    name: Optional[str] = Field(None, max_length=128)
    floating_base: bool = False


# -- answers (documented in OpenAPI; the routes write them directly, arrays never go through pydantic) ---------
class TauAnswer(BaseModel):
    tau: list  # (nv,) or (B, nv)


class AccelerationAnswer(BaseModel):
    a: list


class MassMatrixAnswer(BaseModel):
    mass_matrix: list  # (nv, nv) or (B, nv, nv)


class TrajectoryAnswer(BaseModel):
    t: list
    q: list
    v: list
    tau: list
    report: dict


class RobotSummary(BaseModel):
    id: str
    name: str
    nq: int
    nv: int
    floating_base: bool
    bundled: bool
    joint_names: list[str]
    bodies: list[str]
    warnings: list[str]


class JointInfo(BaseModel):
    name: str
    type: str
    body: str
    parent: Optional[str] = Field(description="parent body, null for the world")
    q_index: int
    v_index: int
    nq: int
    nv: int
    lower: list[Optional[float]]
    upper: list[Optional[float]]
    effort_limit: list[Optional[float]]
    velocity_limit: list[Optional[float]]
    damping: list[float]
    friction: list[float]


class RobotInfo(RobotSummary):
    joints: list[JointInfo]
    gravity: list[float]
    summary: dict


class RobotList(BaseModel):
    robots: list[RobotSummary]


class ErrorAnswer(BaseModel):
    detail: str = Field(description="what was wrong, starting with the field name: 'q: expected shape ...'")
    code: str
    field: Optional[str] = None
