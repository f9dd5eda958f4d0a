"""Request and answer schemas of the HTTP API, in one place, and :func:`validate` (a decoded body -> a request).

State arguments are typed :data:`Array`: one state (a list of nq or nv numbers) or a batch (a list of such
lists); they are turned into float64 arrays in one ``np.asarray`` call, never walked in Python. Their shapes and
finiteness are the library's to check (its messages name the argument and the expected shape); here only what
cannot become an array of numbers is refused. Unknown fields are refused (``extra="forbid"``) so that a typo is
a 422, not a silently ignored option; new optional fields (``locked``; the ``scene`` object of answers) are
added without breaking a caller.

``locked`` ({joint name: value}) selects a reduced model (``dynamics.lock_joints``): the request's states are then
those of the reduced model. Here only its form is checked (names are strings, values numbers or lists of
numbers); joint names, value counts and values are the library's to check, its messages name the joint.
"""

from __future__ import annotations

import json
from typing import Annotated, Any, Literal, Optional, Union

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, ValidationInfo, WithJsonSchema

from .codec import to_array
from .errors import InvalidInput, echo

#: longest name (of a robot, a joint) accepted in a request or kept from a URDF
MAX_NAME = 128

_NUMBERS = {"type": "array", "items": {"type": "number"}, "minItems": 1}
_STATE_SCHEMA = {"anyOf": [_NUMBERS, {"type": "array", "items": _NUMBERS, "minItems": 1}],
                 "description": "one state (a list of nq or nv numbers) or a batch (a list of equal-length lists, "
                                "at most DYNAMICS_MAX_BATCH); their sizes are the robot's (GET the robot): others "
                                "are a 422 naming the argument"}


def _array(value: Any, info: ValidationInfo) -> np.ndarray:
    return to_array(value, info.field_name or "value")


def _locked(value: Any) -> Optional[dict[str, Any]]:
    """{joint: number | [numbers]} (in .npz: that object as a JSON string) -> a dict of floats / float lists."""
    if value is None:
        return None
    if isinstance(value, str):  # .npz carries objects as JSON strings, like the simulation's torque spec
        try:
            value = json.loads(value)
        except json.JSONDecodeError:
            raise InvalidInput("locked: not a JSON object {joint name: value}", "locked") from None
    if not isinstance(value, dict):
        raise InvalidInput(f"locked: expected an object {{joint name: value}}, got {type(value).__name__}", "locked")
    out: dict[str, Any] = {}
    for name, v in value.items():
        where = f"locked[{echo(name)}]"
        if len(name) > MAX_NAME:
            raise InvalidInput(f"{where}: a joint name of {len(name)} characters; joint names have at most "
                               f"{MAX_NAME}", where)
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            out[name] = _float(v, where)
        elif isinstance(v, (list, np.ndarray)) and len(v) <= 7 and all(
                isinstance(x, (int, float, np.floating, np.integer)) and not isinstance(x, (bool, np.bool_))
                for x in (v.tolist() if isinstance(v, np.ndarray) else v)):
            out[name] = [_float(x, where) for x in v]
        else:
            raise InvalidInput(f"{where}: expected a number (1-dof joint) or a list of numbers (7 for a floating "
                               f"joint: x, y, z, qx, qy, qz, qw), got {v!r:.60}", where)
    return out


def _float(x: Any, where: str) -> float:
    try:
        return float(x)
    except OverflowError:  # an integer of hundreds of digits
        raise InvalidInput(f"{where}: {str(x)[:20]}... is too large for a float; expected a finite number",
                           where) from None


def validate(schema: type[BaseModel], payload: dict[str, Any]) -> BaseModel:
    """A decoded body -> the schema, or an InvalidInput whose message starts with the field at fault."""
    try:
        return schema.model_validate(payload)
    except ValidationError as e:
        err = e.errors(include_url=False)[0]
        name = ".".join(str(p) for p in err["loc"]) or "body"
        if err["type"] == "extra_forbidden":
            allowed = ", ".join(schema.model_fields)
            raise InvalidInput(f"{name}: unknown field; expected one of {allowed}", name) from None
        if err["type"] == "union_tag_invalid":
            ctx = err.get("ctx", {})
            raise InvalidInput(f"{name}.type: {ctx.get('tag')!r} is not one of {ctx.get('expected_tags')}",
                               f"{name}.type") from None
        if err["type"] == "missing":
            raise InvalidInput(f"{name}: missing (required)", name) from None
        raise InvalidInput(f"{name}: {err['msg']}", name) from None


Array = Annotated[Any, BeforeValidator(_array), WithJsonSchema(_STATE_SCHEMA)]
_WRENCHES = {"type": "array", "minItems": 1, "items": {"type": "array", "items": {"type": "number"}, "minItems": 6,
                                                       "maxItems": 6}}
Array3 = Annotated[Any, BeforeValidator(_array), WithJsonSchema(
    {"anyOf": [_WRENCHES, {"type": "array", "items": _WRENCHES, "minItems": 1}],
     "description": "(nbodies, 6) or (B, nbodies, 6): [force, torque] per body, body frame"})]
Vec3 = Annotated[Any, BeforeValidator(_array), WithJsonSchema(
    {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3})]
Locked = Annotated[Optional[dict[str, Any]], BeforeValidator(_locked), WithJsonSchema({
    "type": "object", "additionalProperties": {"anyOf": [{"type": "number"}, _NUMBERS]},
    "description": "joints held still at these positions (a number for a 1-dof joint, [x, y, z, qx, qy, qz, qw] "
                   "for a floating one); the other arrays are then those of the reduced model (its nq, nv and "
                   "joint order: GET the robot and drop the locked joints)"})]
Gains = Annotated[Any, BeforeValidator(_array), WithJsonSchema(
    {"anyOf": [{"type": "number"}, _NUMBERS], "description": "a number, or one per velocity coordinate"})]


class _Request(BaseModel):
    # strict: "yes" is no boolean and "1" or true no duration; inf and NaN are no tolerance or duration
    model_config = ConfigDict(extra="forbid", arbitrary_types_allowed=True, strict=True, allow_inf_nan=False)


class _Dynamics(_Request):
    locked: Locked = None
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


class MassMatrixRequest(_Request):  # no gravity: M(q) does not depend on it
    locked: Locked = None
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
    locked: Locked = None
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
    urdf: str = Field(description="the URDF document: a <robot> element (other XML is a 422 naming urdf)",
                      json_schema_extra={"pattern": r"^\s*(<\?xml[^>]*\?>\s*)?(<!--[\s\S]*?-->\s*)*<robot[\s>]"})
    name: Optional[str] = Field(None, max_length=128)
    floating_base: bool = False


# -- answers (documented in OpenAPI; the routes write them directly, arrays never go through pydantic) ---------
class Scene(BaseModel):
    """What the answer's model left out (in .npz answers: a member holding this object as a JSON string)."""
    locked: dict[str, Any] = Field(description="joints held still: {name: position} (a number, or 7 for a floating "
                                               "joint), as the reduced model records them")
    pruned: list[str] = Field(description="URDF links dropped when the model was built (no mass, nothing "
                                          "moving below them)")
    merged_fixed_joints: int = Field(description="URDF fixed joints whose links were merged into their parent")
    skipped: list[str] = Field(description="terms not computed for this request's inputs: 'velocity products' "
                                           "(v = 0), 'joint accelerations' (a = 0), 'gravity' (gravity = 0)")
    nq: int = Field(description="configuration size of the model that answered (the reduced one when locked)")
    nv: int


class TauAnswer(BaseModel):
    tau: list  # (nv,) or (B, nv)
    scene: Scene


class AccelerationAnswer(BaseModel):
    a: list
    scene: Scene


class MassMatrixAnswer(BaseModel):
    mass_matrix: list  # (nv, nv) or (B, nv, nv)
    scene: Scene


class TrajectoryAnswer(BaseModel):
    t: list
    q: list
    v: list
    tau: list
    report: dict
    scene: Scene


class ModelSummary(BaseModel):
    """``dynamics.Model.summary()``: what the model holds and what the builder merged or left out."""
    model_config = ConfigDict(extra="allow")
    name: str
    nq: int
    nv: int
    bodies: int = Field(description="bodies kept (one per movable joint)")
    floating_base: bool
    urdf_links: int
    urdf_joints: int
    fixed_joints_merged: list[str]
    links_pruned: list[str]
    massless_bodies: list[str]
    locked_joints: dict[str, Any]
    meshes_loaded: int
    warnings: list[str]


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


class UploadAnswer(RobotSummary):
    summary: ModelSummary


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
    summary: ModelSummary


class RobotList(BaseModel):
    robots: list[RobotSummary]


class ErrorAnswer(BaseModel):
    detail: str = Field(description="what was wrong, starting with the field name: 'q: expected shape ...'")
    code: str
    field: Optional[str] = None


class ReadyAnswer(BaseModel):
    status: Literal["ready"]
    warmup_seconds: float = Field(description="how long this process's warm-up took")
