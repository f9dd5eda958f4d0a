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
from typing import Annotated, Any, Literal, Optional, Union, get_args

import numpy as np
from pydantic import (BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, ValidationInfo, WithJsonSchema,
                      create_model)

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
                               f"joint: x, y, z, qx, qy, qz, qw; 4 for a spherical joint: qx, qy, qz, qw; 4 for a "
                               f"planar joint: x, y, cos theta, sin theta), got {v!r:.60}", where)
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
            allowed = ", ".join(_fields_at(schema, err["loc"][:-1]))
            raise InvalidInput(f"{name}: unknown field; expected one of {allowed}", name) from None
        if err["type"] == "union_tag_invalid":
            ctx = err.get("ctx", {})
            raise InvalidInput(f"{name}.type: {ctx.get('tag')!r} is not one of {ctx.get('expected_tags')}",
                               f"{name}.type") from None
        if err["type"] == "missing":
            raise InvalidInput(f"{name}: missing (required)", name) from None
        raise InvalidInput(f"{name}: {err['msg']}", name) from None


def _fields_at(schema: type[BaseModel], loc: tuple) -> list[str]:
    """The fields of the object at ``loc`` in ``schema`` (("torque", "pd") -> PDTorque's), following optional
    fields and tagged unions (whose tag is a step of pydantic's error location); the top level's if not found."""
    current: list[Any] = [schema]
    for part in loc:
        step = []
        for model in (m for t in current for m in _models(t)):
            if part in model.model_fields:
                step.append(model.model_fields[part].annotation)
            elif "type" in model.model_fields and part in get_args(model.model_fields["type"].annotation):
                step.append(model)  # the variant of a tagged union that the tag names
        current = step
    models = [m for t in current for m in _models(t)]
    return list(models[0].model_fields) if models else list(schema.model_fields)


def _models(annotation: Any) -> list[type[BaseModel]]:
    """The pydantic models inside a field's annotation (through Optional, Annotated and unions)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for arg in get_args(annotation) for m in _models(arg)]


Array = Annotated[Any, BeforeValidator(_array), WithJsonSchema(_STATE_SCHEMA)]
_MATRIX = {"type": "array", "items": _NUMBERS}
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
                   "for a floating one, [qx, qy, qz, qw] for a spherical one, [x, y, cos theta, sin theta] for a "
                   "planar one); the other arrays are then those of the reduced model (its nq, nv and "
                   "joint order: GET the robot and drop the locked joints)"})]
Gains = Annotated[Any, BeforeValidator(_array), WithJsonSchema(
    {"anyOf": [{"type": "number"}, _NUMBERS], "description": "a number, or one per velocity coordinate"})]


def _matrices(rank: int, what: str) -> dict[str, Any]:
    """The JSON schema of one answer of ``rank`` dimensions (0: a number) or a batch of them."""
    def nested(r: int) -> dict[str, Any]:
        return {"type": "number"} if r == 0 else {"type": "array", "items": nested(r - 1)}
    return {"anyOf": [nested(rank), nested(rank + 1)], "description": f"{what}; a batch adds a leading axis B"}


def Answer(rank: int, what: str) -> Any:  # noqa: N802 - a type, named like one
    """An array field of an answer, typed for OpenAPI (the routes write answers directly, not through pydantic)."""
    return Annotated[Any, WithJsonSchema(_matrices(rank, what))]


def _example(**fields: Any) -> ConfigDict:
    """Requests carry one example each (OpenAPI), on the bundled robot planar-2r unless said otherwise."""
    return ConfigDict(extra="forbid", arbitrary_types_allowed=True, json_schema_extra={"examples": [fields]})


class _Request(BaseModel):
    # strict: "yes" is no boolean and "1" or true no duration; inf and NaN are no tolerance or duration
    model_config = ConfigDict(extra="forbid", arbitrary_types_allowed=True, strict=True, allow_inf_nan=False)


class _Dynamics(_Request):
    locked: Locked = None
    gravity: Optional[Vec3] = Field(None, description="world-frame gravity, default (0, 0, -9.81)")


class InverseDynamicsRequest(_Dynamics):
    model_config = _example(q=[0.3, -0.5], v=[1.0, 2.0], a=[0.5, -1.0])
    q: Array
    v: Array
    a: Array
    f_ext: Optional[Array3] = None


class ForwardDynamicsRequest(_Dynamics):
    model_config = _example(q=[0.3, -0.5], v=[1.0, 2.0], tau=[10.0, 2.0])
    q: Array
    v: Array
    tau: Array
    f_ext: Optional[Array3] = None


class MassMatrixRequest(_Request):  # no gravity: M(q) does not depend on it
    model_config = _example(q=[[0.3, -0.5], [0.0, 1.0]])  # a batch of two states
    locked: Locked = None
    q: Array


class GravityTorquesRequest(_Dynamics):
    model_config = _example(q=[0.3, -0.5], gravity=[0.0, 0.0, -9.81])
    q: Array


class BiasForcesRequest(_Dynamics):
    model_config = _example(q=[0.3, -0.5], v=[1.0, 2.0])
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


class TaskReferenceSpec(_Request):
    """A frame's reference path: t (N,), position (N, 3) in the world, optional velocity and acceleration (N, 3)
    (finite differences otherwise), orientation (N, 3, 3) or (3, 3) (dynamics.torques.TaskReference)."""
    t: Array
    position: Array
    velocity: Optional[Array] = None
    acceleration: Optional[Array] = None
    orientation: Optional[Array] = None


class OperationalSpaceTorque(_Request):
    """Operational-space control of ``frame`` along ``reference``, or to the fixed ``position`` (3,) [and
    ``orientation`` (3, 3)], with a null-space ``posture`` (dynamics.torques.OperationalSpace and Target)."""
    type: Literal["operational_space"]
    frame: Union[str, int]
    reference: Optional[TaskReferenceSpec] = None
    position: Optional[Array] = None
    orientation: Optional[Array] = None
    kp: Gains
    kd: Gains
    rows: Optional[list[int]] = Field(None, description="task rows of [x, y, z, wx, wy, wz]; default position "
                                                        "only, or all 6 with an orientation")
    posture: Optional[Array] = None
    posture_kp: Gains = 0.0
    posture_kd: Optional[Gains] = None
    damping: float = 0.0


TorqueSpec = Annotated[Union[ZeroTorque, ConstantTorque, TableTorque, PDTorque, ComputedTorque,
                             OperationalSpaceTorque], Field(discriminator="type")]


# -- contact with the world (issue 19): the ``contact`` of a simulation, translated by service.contact ---------
#: the most robot geometries plus world objects, pairs, excluded pairs and materials one request may declare;
#: a longer list is refused by its length before any item of it is read
MAX_CONTACT_GEOMETRIES = 512
MAX_CONTACT_PAIRS = 4096
MAX_CONTACT_MATERIALS = 256


def _at_most(limit: int, what: str) -> Any:
    """A BeforeValidator refusing a list longer than ``limit`` at once (pydantic would read every item first: a
    list of 10^6 pairs costs seconds before its length is looked at)."""
    def check(value: Any, info: ValidationInfo) -> Any:
        if isinstance(value, str) and value.lstrip()[:1] in ("[", "{"):  # (.npz: a JSON string)
            try:
                value = json.loads(value)
            except json.JSONDecodeError:
                return value
        if isinstance(value, (list, dict)) and len(value) > limit:
            raise InvalidInput(f"contact.{info.field_name}: {len(value)} {what} is over the limit of {limit}",
                               f"contact.{info.field_name}")
        return value
    return BeforeValidator(check)


Vector3 = Annotated[list[float], Field(min_length=3, max_length=3)]
Pose4 = Annotated[list[Annotated[list[float], Field(min_length=4, max_length=4)]],
                  Field(min_length=4, max_length=4, description="(4, 4) pose [[R, p], [0, 0, 0, 1]] in the frame")]
GeometryName = Optional[str]
_FRAME = ("geometries: the frame of the robot (GET /v1/robots/{id}: frames) the primitive is fixed to (required); "
          "objects: 'world' (the default)")
_LENGTH = {"gt": 0, "le": 1e6}


class _Primitive(_Request):
    frame: Optional[str] = Field(None, min_length=1, max_length=MAX_NAME, description=_FRAME)
    name: Optional[str] = Field(None, min_length=1, max_length=MAX_NAME,
                                description="names the geometry in materials, pairs, exclude and the outputs")


class SphereGeometry(_Primitive):
    """dynamics.Sphere: ``radius`` (m) centred at ``offset`` in the frame."""
    type: Literal["sphere"]
    radius: float = Field(**_LENGTH)
    offset: Optional[Vector3] = None


class BoxGeometry(_Primitive):
    """dynamics.Box: full edge lengths ``size`` (x, y, z, m) at ``pose``; on 'world' a step, a table."""
    type: Literal["box"]
    size: Vector3
    pose: Optional[Pose4] = None


class CapsuleGeometry(_Primitive):
    """dynamics.Capsule: the points within ``radius`` of a segment of ``length`` along the pose's z axis."""
    type: Literal["capsule"]
    radius: float = Field(**_LENGTH)
    length: float = Field(ge=0, le=1e6)
    pose: Optional[Pose4] = None


class CylinderGeometry(_Primitive):
    """dynamics.Cylinder: ``radius`` and ``length`` along the pose's z axis, centred at its origin."""
    type: Literal["cylinder"]
    radius: float = Field(**_LENGTH)
    length: float = Field(**_LENGTH)
    pose: Optional[Pose4] = None


class ContactPointGeometry(_Primitive):
    """dynamics.ContactPoint: a point fixed in the frame (a sole's corner, a fingertip)."""
    type: Literal["point"]
    point: Vector3


class HalfSpaceGeometry(_Request):
    """dynamics.HalfSpace: the solid ``normal . x <= offset`` (a wall, an incline), normal into the free space."""
    type: Literal["half_space"]
    normal: Vector3
    offset: float = 0.0
    name: Optional[str] = Field(None, min_length=1, max_length=MAX_NAME)


RobotGeometry = Annotated[Union[SphereGeometry, BoxGeometry, CapsuleGeometry, CylinderGeometry,
                                ContactPointGeometry], Field(discriminator="type")]
WorldObject = Annotated[Union[SphereGeometry, BoxGeometry, CapsuleGeometry, CylinderGeometry, HalfSpaceGeometry],
                        Field(discriminator="type")]
Pair = Annotated[list[Annotated[str, Field(min_length=1, max_length=MAX_NAME)]], Field(min_length=2, max_length=2)]


class GroundSpec(_Request):
    """dynamics.Ground: the half-space ``normal . x <= height``; an incline is a ground with a tilted normal."""
    normal: Vector3 = Field([0.0, 0.0, 1.0], description="normalised by the library")
    height: float = 0.0


class MaterialSpec(_Request):
    """dynamics.Material; a field left out takes the library's default (the guide's contact page lists them)."""
    stiffness: Optional[float] = Field(None, gt=0, description="N/m; default from the penetration allowance and "
                                                               "the robot's weight")
    dissipation: Optional[float] = Field(None, ge=0, description="Hunt-Crossley d, s/m; default critical damping "
                                                                 "at the allowance")
    mu_static: Optional[float] = Field(None, ge=0, description="default 1")
    mu_dynamic: Optional[float] = Field(None, ge=0, description="default mu_static")
    stiction_velocity: Optional[float] = Field(None, gt=0, description="m/s, default 1e-3")
    penetration_allowance: Optional[float] = Field(None, gt=0, description="m, default 1e-3")


Friction = Union[Annotated[float, Field(ge=0)], MaterialSpec]


class ContactSpec(_Request):
    """dynamics.Contact: compliant contact of the robot's geometry with the ground and the world's objects."""
    ground: Union[GroundSpec, bool] = Field(True, description="true: the plane z = 0 (default); false: no ground")
    friction: Optional[Friction] = Field(None, description="every geometry's material: a Coulomb coefficient "
                                                           "(static = dynamic) or a material; default mu = 1")
    objects: Annotated[list[WorldObject], _at_most(MAX_CONTACT_GEOMETRIES, "objects")] = Field(
        default_factory=list, description="static world objects: boxes, half-spaces, spheres, capsules, cylinders")
    geometries: Annotated[Optional[list[RobotGeometry]], _at_most(MAX_CONTACT_GEOMETRIES, "geometries")] = Field(
        None, description="the robot's contact geometry; default the URDF's collision primitives (GET the robot: "
                          "collision_geometry)")
    materials: Annotated[Optional[dict[str, Friction]], _at_most(MAX_CONTACT_MATERIALS, "materials")] = Field(
        None, description="materials by geometry name ('ground', a geometry's or object's name)")
    pairs: Annotated[Optional[list[Pair]], _at_most(MAX_CONTACT_PAIRS, "pairs")] = Field(
        None, description="only these pairs of geometry names may touch; default every pair the filters allow")
    self_collision: bool = Field(False, description="the robot's geometries touch each other (adjacent bodies "
                                                    "never)")
    exclude: Annotated[list[Pair], _at_most(MAX_CONTACT_PAIRS, "exclude")] = Field(
        default_factory=list, description="pairs of geometry or body names that never touch")
    outputs: list[Literal["contacts"]] = Field(
        default_factory=list, max_length=1, description="['contacts']: every active contact per sample in the answer "
                                                        "(contact.point, normal, normal_force, friction, depth, slip; "
                                                        "world frame)")


class SimulateRequest(_Request):
    model_config = _example(q0=[0.3, -0.2], v0=[0.0, 0.5], duration=1.0, sample_dt=0.01, integrator="auto",
                            torque={"type": "pd", "q_target": [0.5, 0.5], "kp": 50.0, "kd": 4.0})
    locked: Locked = None
    q0: Array
    v0: Array
    duration: float = Field(gt=0, description="seconds of simulated time")
    torque: Optional[TorqueSpec] = None
    integrator: Optional[Literal["euler", "implicit_euler", "rk4", "rk45", "dop853", "radau", "auto"]] = Field(
        None, description="default 'auto' (adaptive, switches to radau when stiff); dop853: Hairer's order 8, for "
                          "tight tolerances; euler, implicit_euler (contact and stiff gains at a fixed step) and rk4 need dt")
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
    outputs: Optional[list[Literal["q", "v", "tau", "lambda"]]] = Field(
        None, max_length=4, description="what to keep per sample besides t, default [q, v, tau]; the others come "
                                        "back empty. 'lambda': the constraint multipliers of a robot with closed "
                                        "loops or couplings (K, m), in the units of constrained-forward-dynamics")
    baumgarte: Optional[list[float]] = Field(None, min_length=2, max_length=2,
                                             description="robots with constraints: (alpha, beta) in 1/s, default "
                                                         "(10, 10); [0, 0] for none")
    project: Optional[bool] = Field(None, description="robots with constraints: project (q, v) onto the constraint "
                                                      "manifold after every accepted step (default false)")
    contact: Optional[ContactSpec] = Field(None, description="contact with the ground and the world's objects "
                                                             "(dynamics.Contact); default none: the robot touches "
                                                             "nothing")
    sensitivities: Optional[Union[bool, list[str]]] = Field(
        None, description="forward sensitivities dx(t)/d(x0, parameters), x = (q, v), integrated with the state under "
                          "the same error control: true (x0), or names among 'x0' and the torque's parameters (pd: "
                          "kp, kd, q_target, v_target, tau_ff; computed_torque: kp, kd; constant and table: tau); "
                          "answered as 'sensitivities' (K, 2 nv, ncol), the columns named in "
                          "report.sensitivities.columns. Robots of 1-dof joints; not with euler, implicit_euler or project")


#: the SimulateRequest fields passed on to dynamics.simulate as keyword arguments (None = library default)
SIMULATE_OPTIONS = ("integrator", "rtol", "atol", "dt", "sample_dt", "gravity", "limits", "limit_stiffness",
                    "limit_damping", "friction_eps", "error_estimate", "outputs", "baumgarte", "project",
                    "sensitivities")


class UploadRequest(_Request):
    model_config = _example(name="my-pendulum", floating_base=False, urdf=(
        '<robot name="my-pendulum"><link name="base"/><link name="bob"><inertial><origin xyz="0 0 -1"/>'
        '<mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        '<joint name="swing" type="revolute"><parent link="base"/><child link="bob"/><axis xyz="0 1 0"/>'
        '<limit lower="-3" upper="3" effort="10" velocity="10"/></joint></robot>'))
    urdf: str = Field(description="the URDF document: a <robot> element (other XML is a 422 naming urdf)",
                      json_schema_extra={"pattern": r"^\s*(<\?xml[^>]*\?>\s*)?(<!--[\s\S]*?-->\s*)*<robot[\s>]"})
    name: Optional[str] = Field(None, max_length=128)
    floating_base: bool = False
    constraints: Optional[list["ConstraintSpec"]] = Field(
        None, max_length=256, description="closed loops and joint couplings added to the URDF's own (its <loop> and "
                                          "<mimic> elements); stored in the robot's document as such elements")
    mimic: Optional[Literal["coupling", "independent"]] = Field(
        None, description="URDF <mimic>: 'coupling' (default, a JointCoupling constraint) or 'independent' (ignored)")


# -- answers (documented in OpenAPI; the routes write them directly, arrays never go through pydantic) ---------
class Scene(BaseModel):
    """What the answer's model left out (in .npz answers: a member holding this object as a JSON string)."""
    locked: dict[str, Any] = Field(description="joints held still: {name: position} (a number, 7 for a floating "
                                               "joint, 4 for a spherical or planar one), as the reduced model "
                                               "records them")
    links_pruned: list[str] = Field(description="URDF links dropped when the model was built (no mass, nothing "
                                                "moving below them), as in the model summary")
    fixed_joints_merged: list[str] = Field(description="URDF fixed joints whose links were merged into their parent, "
                                                       "as in the model summary")
    skipped: list[str] = Field(description="terms not computed for this request's inputs: 'velocity products' "
                                           "(v = 0), 'joint accelerations' (a = 0), 'gravity' (gravity = 0)")
    nq: int = Field(description="configuration size of the model that answered (the reduced one when locked)")
    nv: int


class TauAnswer(BaseModel):
    tau: Answer(1, "(nv,) joint torques (N m or N)")
    scene: Scene


class AccelerationAnswer(BaseModel):
    a: Answer(1, "(nv,) joint accelerations")
    scene: Scene


class MassMatrixAnswer(BaseModel):
    mass_matrix: Answer(2, "(nv, nv)")
    scene: Scene


class InverseDynamicsDerivativesAnswer(BaseModel):
    dtau_dq: Answer(2, "(nv, nv) dtau/dq, q in the tangent space (a free joint's along q (+) dq, body frame)")
    dtau_dv: Answer(2, "(nv, nv) dtau/dv")
    mass_matrix: Answer(2, "(nv, nv) M(q) = dtau/da")
    scene: Scene


class ForwardDynamicsDerivativesAnswer(BaseModel):
    da_dq: Answer(2, "(nv, nv) da/dq, q in the tangent space")
    da_dv: Answer(2, "(nv, nv) da/dv")
    inverse_mass_matrix: Answer(2, "(nv, nv) M(q)^-1 = da/dtau")
    scene: Scene


class TrajectoryAnswer(BaseModel):
    t: list[float] = Field(description="(K,) sample times, s")
    q: list[list[float]] = Field(description="(K, nq) configurations at the samples")
    v: list[list[float]] = Field(description="(K, nv) velocities")
    tau: list[list[float]] = Field(description="(K, nv) applied joint torques")
    lam: Optional[list[list[float]]] = Field(None, alias="lambda",
                                             description="(K, m) constraint multipliers, when outputs has 'lambda'")
    contacts_sample: Optional[list[int]] = Field(
        None, alias="contacts.sample", description="with contact.outputs ['contacts'], one row per active contact "
                                                   "per sample, in sample order: (N,) the index of its sample")
    contacts_pair: Optional[list[int]] = Field(None, alias="contacts.pair",
                                               description="(N,) index into contacts.pairs")
    contacts_pairs: Optional[list[list[str]]] = Field(None, alias="contacts.pairs", description=(
        "(P, 2) the geometry names of each candidate pair (a, b); the normal points from b to a"))
    contacts_point: Optional[list[list[float]]] = Field(None, alias="contacts.point",
                                                        description="(N, 3) contact point, world frame, m")
    contacts_normal: Optional[list[list[float]]] = Field(None, alias="contacts.normal",
                                                         description="(N, 3) unit normal from b towards a")
    contacts_normal_force: Optional[list[float]] = Field(None, alias="contacts.normal_force",
                                                         description="(N,) f_n >= 0 on a, N")
    contacts_friction: Optional[list[list[float]]] = Field(None, alias="contacts.friction",
                                                           description="(N, 3) friction force on a, world frame, N")
    contacts_depth: Optional[list[float]] = Field(None, alias="contacts.depth", description="(N,) penetration, m")
    contacts_slip: Optional[list[list[float]]] = Field(None, alias="contacts.slip", description=(
        "(N, 3) tangential velocity of a relative to b at the point, m/s"))
    sensitivities: Optional[list[list[list[float]]]] = Field(
        None, description="(K, 2 nv, ncol) dx/d(x0, parameters) at the samples, when the request asked for them")
    report: dict[str, Any] = Field(description="dynamics.Trajectory.report: status, integrator, steps, "
                                               "error_estimate, energy_drift, warnings, wall time, ...")
    scene: Scene


class ModelSummary(BaseModel):
    """``dynamics.Model.summary()``: what the model holds and what the builder merged or left out."""
    model_config = ConfigDict(extra="allow")
    name: str
    nq: int
    nv: int
    bodies: int = Field(description="bodies kept (one per movable joint)")
    floating_base: bool
    joint_types: dict[str, int] = Field({}, description="movable joints per type: revolute, continuous, prismatic, "
                                                        "floating, planar, spherical")
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
    constraints: Optional["ConstraintsInfo"] = Field(None, description="loops and couplings; absent when none")


class JointInfo(BaseModel):
    name: str
    type: str = Field(description="revolute, continuous, prismatic, floating (q: x, y, z, qx, qy, qz, qw), "
                                  "planar (q: x, y, cos theta, sin theta) or spherical (q: qx, qy, qz, qw)")
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


class FrameInfo(BaseModel):
    name: str
    body: Optional[str] = Field(description="the body the frame is fixed to, null for the world")
    placement: list[list[float]] = Field(description="(4, 4) pose of the frame in that body's frame (or the world)")


class CollisionItem(BaseModel):
    """One collision primitive of the robot (dynamics.CollisionGeometry)."""
    name: str = Field(description="names it in a contact's materials, pairs and exclude")
    body: Optional[str] = Field(description="the body it is fixed to (its link may have been merged into it)")
    frame: str = Field(description="the URDF link it was declared on")
    kind: Literal["sphere", "box", "capsule", "cylinder", "point"]
    size: list[float] = Field(description="sphere (radius, 0, 0); box full edges (x, y, z); capsule and cylinder "
                                          "(radius, length, 0), axis along the local z; point (0, 0, 0); m")
    pose: list[list[float]] = Field(description="(4, 4) pose in the body's frame")


class RobotInfo(RobotSummary):
    joints: list[JointInfo]
    gravity: list[float]
    total_mass: float = Field(description="kg, all bodies (links welded to a fixed base's world are not bodies)")
    masses: list[float] = Field(description="(nbodies,) kg, in the order of bodies (dynamics.Model.masses)")
    coms: list[list[float]] = Field(description="(nbodies, 3) centre of mass of each body in its body frame, m")
    inertias: list[list[list[float]]] = Field(description="(nbodies, 3, 3) rotational inertia of each body about "
                                                          "its centre of mass, body frame, kg m^2")
    frames: list[FrameInfo] = Field(description="every frame (URDF links and joints), in the order of the "
                                                "kinematics answers")
    summary: ModelSummary
    constraints: Optional["ConstraintsInfo"] = Field(None, description="loops and couplings; absent when none")
    collision_geometry: list[CollisionItem] = Field(
        default_factory=list, description="the URDF's collision primitives (meshes are left out), the contact "
                                          "geometry of a simulation whose contact declares none")


class BodyInspection(BaseModel):
    """One body as the inspector draws it: its joint and the check of its mass properties (body frame)."""
    name: str
    parent: int = Field(description="index of the parent body, -1 for the world")
    joint: str
    joint_type: str
    axis: list[float] = Field(description="(3,) joint axis in the joint (= body) frame")
    placement: list[list[float]] = Field(description="(4, 4) joint frame in the parent body frame at q = 0")
    mass: float
    com: list[float]
    inertia: list[list[float]] = Field(description="(3, 3) about the centre of mass, kg m^2")
    principal_moments: list[float] = Field(description="(3,) ascending, kg m^2")
    principal_axes: list[list[float]] = Field(description="(3, 3) columns: the principal axes (a rotation)")
    positive_definite: bool
    triangle: bool = Field(description="principal moments obey I3 <= I1 + I2")
    relative_violation: float
    verdict: Literal["ok", "warning", "refused"] = Field(description="what load_urdf's thresholds make of it")
    box: list[float] = Field(description="(3,) edges of the uniform box of the same mass and inertia, m")


class InspectedGeometry(BaseModel):
    """One collision primitive of the robot (dynamics.CollisionGeometry)."""
    name: str
    body: Optional[str] = Field(description="the body it is fixed to (its link may have been merged into it); "
                                            "null for the world")
    frame: str
    kind: str = Field(description="sphere, box, capsule, cylinder or point")
    size: list[Optional[float]] = Field(description="sphere (r, 0, 0); box full edges; capsule and cylinder "
                                                    "(radius, length along local z, 0)")
    pose: list[list[float]] = Field(description="(4, 4) in the body frame")


class RobotInspection(RobotInfo):
    """The description and what the inspector page draws (GET /v1/robots/{id}/inspect)."""
    bodies_inspected: list[BodyInspection] = Field(description="per body, in the order of bodies")
    collision_geometry: list[InspectedGeometry] = Field(description="the URDF's collision primitives (meshes are "
                                                                    "left out); empty when it has none")
    neutral: list[float] = Field(description="(nq,) the model's neutral configuration (dynamics.Model.neutral), "
                                             "where the inspector's pose tab starts")


class RobotList(BaseModel):
    robots: list[RobotSummary]


class ErrorAnswer(BaseModel):
    detail: str = Field(description="what was wrong, starting with the field name: 'q: expected shape ...'")
    code: str
    field: Optional[str] = None


class HealthAnswer(BaseModel):
    status: Literal["ok"]


class ReadyAnswer(BaseModel):
    status: Literal["ready"] = Field(description="always 'ready': the server takes requests once it has started "
                                                 "(it has no warm-up)")


# -- kinematics and task space (issue 9), the Coriolis matrix and the energies (issue 13) -----------------------
#: the most iterations an inverse-kinematics request may ask (one state cannot be stopped by the time budget)
MAX_IK_ITER = 10_000


def _json_list(value: Any) -> Any:
    """A list of names or indices; in .npz a JSON string or an array, as the client sends it."""
    if isinstance(value, str) and value.lstrip().startswith("["):
        try:
            return json.loads(value)
        except json.JSONDecodeError:
            return value
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


Frame = Annotated[Union[str, int], Field(description="a frame name (GET /v1/robots/{id}: frames) or its index; "
                                                     "every URDF link and joint is a frame")]
Reference = Optional[Literal["local_world_aligned", "local", "world"]]
_REFERENCE = ("'local_world_aligned' (default: the frame origin, world axes), 'local' (the frame's axes) or 'world' "
              "(spatial, at the world origin), as in Pinocchio")
Names = Annotated[Optional[list[str]], BeforeValidator(_json_list)]
Rows = Annotated[Optional[list[int]], BeforeValidator(_json_list)]
Pose = Annotated[Any, BeforeValidator(_array), WithJsonSchema(
    {"anyOf": [_MATRIX, {"type": "array", "items": _MATRIX}, _NUMBERS],
     "description": "a (4, 4) world pose [[R, p], [0, 0, 0, 1]], or a batch (B, 4, 4); with position_only a "
                    "position (3,) or (B, 3)"})]


class KinematicsRequest(_Request):
    """The world placement (4, 4) of each asked frame (dynamics.forward_kinematics)."""
    model_config = _example(q=[0.3, -0.5], frames=["link2", "tip"])
    locked: Locked = None
    q: Array
    frames: Names = Field(None, description="frame names, default all (in the robot's frame order)")


class JacobianRequest(_Request):
    """The frame's Jacobian (6, nv), rows [linear; angular] (dynamics.frame_jacobian)."""
    model_config = _example(q=[0.3, -0.5], frame="tip", reference="local_world_aligned")
    locked: Locked = None
    q: Array
    frame: Frame
    reference: Reference = Field(None, description=_REFERENCE)
    point: Optional[Vec3] = Field(None, description="a point fixed on the frame, in the frame's axes: the linear "
                                                    "rows are its velocity")


class CenterOfMassRequest(_Request):
    """The centre of mass, its Jacobian and (given v) its velocity (dynamics.center_of_mass, com_jacobian,
    center_of_mass_velocity)."""
    model_config = _example(q=[0.3, -0.5], v=[1.0, 0.0])
    locked: Locked = None
    q: Array
    v: Optional[Array] = Field(None, description="velocities: the answer then has center_of_mass_velocity")


class InverseMassMatrixRequest(_Request):
    """M(q)^-1 computed directly in O(n^2) (dynamics.inverse_mass_matrix)."""
    model_config = _example(q=[0.3, -0.5])
    locked: Locked = None
    q: Array


class OperationalSpaceInertiaRequest(_Request):
    """Lambda = (J M^-1 J^T)^-1 for the frame's Jacobian rows (dynamics.operational_space_inertia)."""
    model_config = _example(q=[0.3, -0.5], frame="tip", rows=[0, 2])
    locked: Locked = None
    q: Array
    frame: Frame
    reference: Reference = Field(None, description=_REFERENCE)
    rows: Rows = Field(None, description="rows of [linear; angular] kept (0-2 linear, 3-5 angular), default all 6")
    damping: Optional[float] = Field(None, ge=0, description="d > 0 gives (J M^-1 J^T + d 1)^-1; default 0, and a "
                                                             "singular J M^-1 J^T is a 422")


class InverseKinematicsRequest(_Request):
    """A configuration placing the frame at the target, by damped least squares from q0
    (dynamics.inverse_kinematics). An unreachable target is reported (report.converged false), not refused."""
    model_config = _example(frame="tip", target=[1.2, 0.0, 0.8], q0=[0.1, 0.1], position_only=True)
    locked: Locked = None
    frame: Frame
    target: Pose
    q0: Array
    position_only: Optional[bool] = Field(None, description="only the position (3 rows); default false")
    tol: Optional[float] = Field(None, gt=0, description="on |e| (m and rad), default 1e-10")
    max_iter: Optional[int] = Field(None, ge=0, le=MAX_IK_ITER, description="default 100")
    damping: Optional[float] = Field(None, ge=0, description="smallest damping lambda (mu >= lambda^2), default 1e-6")
    respect_limits: Optional[bool] = Field(None, description="keep 1-dof joints within their URDF limits")


class CoriolisMatrixRequest(_Request):
    """C(q, v) with C v + g(q) = h(q, v) and dM/dt - 2 C skew-symmetric (dynamics.coriolis_matrix)."""
    model_config = _example(q=[0.3, -0.5], v=[1.0, 2.0])
    locked: Locked = None
    q: Array
    v: Array


class KineticEnergyRequest(_Request):
    """T = 1/2 v^T M(q) v (dynamics.kinetic_energy)."""
    model_config = _example(q=[0.3, -0.5], v=[1.0, 2.0])
    locked: Locked = None
    q: Array
    v: Array


class PotentialEnergyRequest(_Dynamics):
    """U = -sum m_i g . c_i, zero at the world origin (dynamics.potential_energy)."""
    model_config = _example(q=[0.3, -0.5])
    q: Array


class KinematicsAnswer(BaseModel):
    placements: Answer(3, "(nframes, 4, 4) world placements [[R, p], [0, 0, 0, 1]], in the order of frames")
    frames: list[str] = Field(description="the frames of placements, in order")
    scene: Scene


class JacobianAnswer(BaseModel):
    jacobian: Answer(2, "(6, nv), rows [linear; angular] in the asked reference")
    scene: Scene


class CenterOfMassAnswer(BaseModel):
    center_of_mass: Answer(1, "(3,) world position of the centre of mass, m")
    com_jacobian: Answer(2, "(3, nv): center_of_mass_velocity = com_jacobian v")
    center_of_mass_velocity: Optional[Answer(1, "(3,) m/s, when v was given")] = None
    total_mass: float = Field(description="kg")
    scene: Scene


class InverseMassMatrixAnswer(BaseModel):
    inverse_mass_matrix: Answer(2, "(nv, nv)")
    scene: Scene


class OperationalSpaceInertiaAnswer(BaseModel):
    operational_space_inertia: Answer(2, "(r, r) for the r asked rows")
    scene: Scene


class InverseKinematicsReport(BaseModel):
    """One value per field, or a list of B for a batch."""
    converged: Union[bool, list[bool]]
    status: Union[Literal["converged", "max_iter", "stalled"], list[str]] = Field(
        description="'stalled': no step reduces the error any more (e.g. an unreachable target)")
    iterations: Union[int, list[int]]
    residual: Union[float, list[float]] = Field(description="|e| at q (m and rad; position only: m)")
    position_error: Union[float, list[float]] = Field(description="m")
    orientation_error: Union[float, list[float]] = Field(description="rad")


class InverseKinematicsAnswer(BaseModel):
    q: Answer(1, "(nq,) the best configuration found (also when not converged)")
    report: InverseKinematicsReport
    scene: Scene


class CoriolisMatrixAnswer(BaseModel):
    coriolis_matrix: Answer(2, "(nv, nv)")
    scene: Scene


class KineticEnergyAnswer(BaseModel):
    kinetic_energy: Answer(0, "J")
    scene: Scene


class PotentialEnergyAnswer(BaseModel):
    potential_energy: Answer(0, "J")
    scene: Scene
# -- jobs (POST /v1/jobs; service.jobs) -------------------------------------------------------------------------
JOB_KINDS = ("simulate_many", "inverse_dynamics", "forward_dynamics", "mass_matrix")
_JOB_OPTION_FIELDS = {name: (f.annotation, f) for name, f in SimulateRequest.model_fields.items()
                      if name in SIMULATE_OPTIONS or name in ("locked", "contact")}
#: a job's options: simulate's (duration required for simulate_many), gravity for dynamics, locked joints
JobOptions = create_model("JobOptions", __base__=_Request, **_JOB_OPTION_FIELDS,
                          duration=(Optional[float], Field(None, gt=0, description="simulate_many: seconds per run")))


class JobRequest(_Request):
    """A batch too large for one request, run as a job (``inputs``: arrays by name; see the README's Jobs)."""
    robot: str
    kind: Literal["simulate_many", "inverse_dynamics", "forward_dynamics", "mass_matrix"]
    inputs: dict[str, Any] = Field(description="simulate_many: q0 (B, nq) or (nq,), v0, optional torque spec whose "
                                               "array fields may have one row per run; inverse_dynamics: q, v, a "
                                               "(B, n); forward_dynamics: q, v, tau; mass_matrix: q")
    options: JobOptions = Field(default_factory=JobOptions)


class JobProgress(BaseModel):
    done: int
    total: int
    fraction: float


class JobStatus(BaseModel):
    id: str
    robot: str
    kind: str
    status: Literal["queued", "running", "done", "failed", "cancelled", "removed"] = Field(
        description="'removed' only in the answer to DELETE of a finished job")
    progress: JobProgress
    created: float = Field(description="Unix time of submission")
    started: Optional[float]
    finished: Optional[float]
    timing: dict[str, Optional[float]] = Field(description="queued_seconds, running_seconds, compute_seconds")
    error: Optional[str] = Field(description="why it failed, or why it was restarted")
    attempts: int
    status_url: str
    result_url: Optional[str] = Field(description="once done")
    result_bytes: int
    expires: Optional[float] = Field(description="Unix time when the finished job and its result are removed")


class JobList(BaseModel):
    jobs: list[JobStatus]



# -- closed loops and coupled joints (issue 10) ------------------------------------------------------------------
class PointSpec(_Request):
    """dynamics.PointConstraint: point_a on frame_a coincides with point_b on frame_b (3 rows)."""
    type: Literal["point"]
    frame_a: str
    frame_b: str
    point_a: Optional[Vec3] = Field(None, description="in frame_a's coordinates, default its origin")
    point_b: Optional[Vec3] = Field(None, description="in frame_b's coordinates, default its origin")
    name: Optional[str] = Field(None, max_length=64)


class WeldSpec(_Request):
    """dynamics.WeldConstraint: frame_b keeps the pose ``placement`` in frame_a (6 rows)."""
    type: Literal["weld"]
    frame_a: str
    frame_b: str
    placement: Optional[Pose] = Field(None, description="(4, 4); default the relative pose at the neutral q")
    name: Optional[str] = Field(None, max_length=64)


class RevoluteSpec(_Request):
    """dynamics.RevoluteConstraint: a hinge closure (5 rows)."""
    type: Literal["revolute"]
    frame_a: str
    frame_b: str
    axis: Vec3 = Field(description="the hinge axis in frame_a's coordinates")
    point_a: Optional[Vec3] = None
    point_b: Optional[Vec3] = None
    axis_b: Optional[Vec3] = Field(None, description="the axis in frame_b's coordinates, default the same numbers")
    name: Optional[str] = Field(None, max_length=64)


class CouplingSpec(_Request):
    """dynamics.JointCoupling: q_follower = multiplier q_leader + offset (1 row), what URDF <mimic> means."""
    type: Literal["coupling"]
    follower: str
    leader: str
    multiplier: float = 1.0
    offset: float = 0.0
    name: Optional[str] = Field(None, max_length=64)


ConstraintSpec = Annotated[Union[PointSpec, WeldSpec, RevoluteSpec, CouplingSpec], Field(discriminator="type")]
UploadRequest.model_rebuild()


def _json_value(value: Any) -> Any:
    """A list or an object; in .npz a JSON string (as the client sends it) or an array of names."""
    if isinstance(value, str) and value.lstrip()[:1] in ("[", "{"):
        try:
            return json.loads(value)
        except json.JSONDecodeError:
            return value
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


Fixed = Annotated[Optional[Union[list[str], dict[str, Union[float, list[float]]]]], BeforeValidator(_json_value)]
#: the most Gauss-Newton iterations an assembly request may ask per guess
MAX_ASSEMBLE_ITER = 1_000


class ConstraintResidualRequest(_Request):
    """phi(q), zero when every loop is closed and every coupling holds (dynamics.constraint_residual)."""
    model_config = _example(q=[0.3, -0.5])
    locked: Locked = None
    q: Array


class AssembleRequest(_Request):
    """A configuration closing every loop near q_guess, by Gauss-Newton (dynamics.assemble)."""
    model_config = _example(q_guess=[0.3, -0.5], fixed=["joint1"])
    locked: Locked = None
    q_guess: Array
    fixed: Fixed = Field(None, description="joints kept at their value in q_guess (a list of names), or "
                                           "{name: value}")
    tol: Optional[float] = Field(None, gt=0, description="on max |phi|, default 1e-12")
    max_iter: Optional[int] = Field(None, ge=1, le=MAX_ASSEMBLE_ITER, description="per guess, default 100")


class ConstrainedForwardDynamicsRequest(_Dynamics):
    """(a, lambda) of the constrained model (dynamics.constrained_forward_dynamics)."""
    model_config = _example(q=[0.3, -0.5], v=[1.0, 2.0], tau=[10.0, 2.0], baumgarte=[10.0, 10.0])
    q: Array
    v: Array
    tau: Array
    baumgarte: Optional[list[float]] = Field(None, min_length=2, max_length=2,
                                             description="(alpha, beta) in 1/s; default none")


class ConstrainedInverseDynamicsRequest(_Dynamics):
    """Torques of the actuated joints for a motion the loops allow (dynamics.constrained_inverse_dynamics)."""
    model_config = _example(q=[0.3, -0.5], v=[1.0, 2.0], a=[0.5, -1.0], actuated=["joint1", "joint2"])
    q: Array
    v: Array
    a: Array
    actuated: Annotated[list[str], BeforeValidator(_json_list)] = Field(description="the actuated joints' names")


class ConstraintResidualAnswer(BaseModel):
    residual: Answer(1, "(m,) phi(q): m, rad, or a joint's units for couplings")
    scene: Scene


class AssembleAnswer(BaseModel):
    q: Answer(1, "(nq,) a configuration with max |phi| <= tol")
    scene: Scene


class ConstrainedForwardDynamicsAnswer(BaseModel):
    a: Answer(1, "(nv,) accelerations")
    lam: Answer(1, "(m,) minimum-norm multipliers in physical units (world axes; force on frame_a's body at its "
                   "anchor, N; torques, N m)") = Field(alias="lambda")
    scene: Scene


class ConstrainedForwardDynamicsDerivativesAnswer(BaseModel):
    da_dq: Answer(2, "(nv, nv) da/dq, q in the tangent space")
    da_dv: Answer(2, "(nv, nv) da/dv")
    da_dtau: Answer(2, "(nv, nv) da/dtau")
    dlambda_dq: Answer(2, "(m, nv) dlambda/dq (the minimum-norm multipliers')")
    dlambda_dv: Answer(2, "(m, nv) dlambda/dv")
    dlambda_dtau: Answer(2, "(m, nv) dlambda/dtau")
    scene: Scene


class ConstraintItem(BaseModel):
    type: Literal["point", "weld", "revolute", "coupling"]
    name: str
    rows: int
    frame_a: Optional[str] = None
    frame_b: Optional[str] = None
    point_a: Optional[list[float]] = None
    point_b: Optional[list[float]] = None
    axis: Optional[list[float]] = None
    axis_b: Optional[list[float]] = None
    placement: Optional[list[list[float]]] = None
    follower: Optional[str] = None
    leader: Optional[str] = None
    multiplier: Optional[float] = None
    offset: Optional[float] = None


class ConstraintsInfo(BaseModel):
    """The model's constraints (dynamics.Model.constraints, in the order of phi's rows) and their rank."""
    items: list[ConstraintItem]
    rows: int
    rank: int = Field(description="of Phi_q where the loops close near the neutral configuration")
    mobility: int = Field(description="nv - rank: the mechanism's degrees of freedom")


UploadAnswer.model_rebuild()
RobotInfo.model_rebuild()
