"""Contact against MuJoCo and Drake (issue 19, section 6): `python -m benchmarks.contact`.

Scenes (each robot a URDF that every tool reads with its own URDF compiler; the world added by each tool):

* ``ball``: a 1 kg ball of radius 0.1 m dropped from 1 m onto the ground; observable: the apex height of the
  first bounce, z + vz^2 / (2 g) at a time in the flight after it (exact in free flight, so no sampling error);
* ``incline``: a 1 kg box of 0.2 m on a 30 degree incline with mu = 0.5 (tan 30 deg = 0.58 > mu), released at
  rest; observable: the distance slid along the incline after 1 s (Coulomb: 1/2 g (sin - mu cos) t^2);
* ``quadruped``: Go1 (example-robot-data, sphere feet) standing on the ground under joint PD springs, 1 s from
  its feet touching; observables: the sum of the normal forces at the end over m g, and the base height.

The tools, each with its error-controlled or default stepping over a range of settings:

* **ours**: ``dynamics.simulate(..., contact=dynamics.Contact(...))`` (``auto`` and ``rk45``/``radau`` over
  rtol);
* **MuJoCo**: the URDF through MuJoCo's compiler (``MjSpec.from_string``), a free joint and a ground plane
  added, its default soft contacts (solref, solimp) with the scene's friction, stepped by ``mujoco.rollout`` (a
  C loop) with its default Euler integrator at its default step (2 ms) and smaller ones;
* **Drake**: the URDF through Drake's parser, a MultibodyPlant in continuous time (``time_step=0``) with
  compliant point contact (Hunt-Crossley, the scene's stiffness and dissipation), stepped by its
  error-controlled ``runge_kutta3`` over ``set_target_accuracy`` (the ``bench`` extra; without ``pydrake`` its
  runs are left out and said so).

The error of a run is its observable's distance to the same tool's observable at its tightest setting (the
tools' contact models differ, so each converges to its own answer; those answers and the analytic one are
printed side by side).  Times are wall seconds per simulated second, best over ``--repeat`` rounds of a round
robin in which every run of every tool takes its turn (every tool sees the same load).  Output: markdown tables
(printed and in benchmarks/out/contact.md).
"""

from __future__ import annotations

import argparse
import importlib.metadata
import math
import os
import re
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, NamedTuple, Optional

import numpy as np

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "benchmarks" / "out"
G = 9.81
ERROR_LEVELS = (1e-1, 1e-2, 1e-3, 1e-4)


def erd(rel: str) -> str:
    dist = importlib.metadata.distribution("example-robot-data")
    return str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots") / rel)


# -- the scenes ------------------------------------------------------------------------------------------------
class State(NamedTuple):
    """A tool-neutral state: base position (3,), base orientation (w, x, y, z), base linear and angular velocity
    in the world (3,) each, joint positions and velocities by name, the sum of the contact normal forces (N)."""
    p: np.ndarray
    quat_wxyz: np.ndarray
    v_lin: np.ndarray
    w: np.ndarray
    joints: dict[str, float]
    normal_force: float


@dataclass(frozen=True)
class Scene:
    name: str
    urdf: str                      # the robot, as every tool reads it (floating base)
    duration: float
    p0: tuple                      # base position at t = 0
    quat0: tuple                   # base orientation (w, x, y, z)
    joints0: dict = field(default_factory=dict)  # joint positions at t = 0 (and the PD targets)
    normal: tuple = (0.0, 0.0, 1.0)  # the ground's normal (an incline: tilted)
    mu: float = 0.5
    stiffness: float = 1e5         # N/m, Hunt-Crossley k of the pair
    dissipation: float = 0.2       # s/m, Hunt-Crossley d of the pair
    stiction: float = 1e-3         # m/s, regularised friction's stiction velocity
    kp: float = 0.0                # joint PD springs, N m/rad
    kd: float = 0.0                # joint damping, N m s/rad (written into the URDF)
    mass: float = 1.0
    mujoco_solref: tuple = (0.02, 1.0)  # MuJoCo's default (time constant s, damping ratio)

    def observable(self, s: State) -> float:
        return OBSERVABLES[self.name](self, s)

    def analytic(self) -> Optional[float]:
        if self.name == "incline":
            th = math.acos(self.normal[2])
            return 0.5 * G * (math.sin(th) - self.mu * math.cos(th)) * self.duration ** 2
        if self.name == "quadruped":
            return 1.0  # sum of normal forces / (m g) at rest
        return None


def _apex(scene: Scene, s: State) -> float:
    return float(s.p[2] + s.v_lin[2] ** 2 / (2 * G))


def _slide(scene: Scene, s: State) -> float:
    n = np.array(scene.normal)
    down = np.array([0.0, 0.0, -1.0]) - n * (-n[2])  # gravity's direction projected on the incline
    down /= np.linalg.norm(down)
    return float((s.p - np.array(scene.p0)) @ down)


def _stand(scene: Scene, s: State) -> float:
    return float(s.normal_force / (scene.mass * G))


OBSERVABLES = {"ball": _apex, "incline": _slide, "quadruped": _stand}
UNITS = {"ball": "apex height (m)", "incline": "slide distance (m)", "quadruped": "sum Fn / (m g)"}


def _inertial(mass: float, ixx: float, iyy: float, izz: float) -> str:
    return (f'<inertial><mass value="{mass}"/><inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="0" ixz="0" '
            f'iyz="0"/></inertial>')


def ball_scene() -> Scene:
    r, m = 0.1, 1.0
    i = 0.4 * m * r * r
    urdf = (f'<robot name="ball"><link name="ball">{_inertial(m, i, i, i)}<collision><geometry>'
            f'<sphere radius="{r}"/></geometry></collision></link></robot>')
    # (flight after the first bounce, for every tool and setting: lift-off ~0.45 s, next touch-down > 0.8 s)
    # MuJoCo's default contact is critically damped (no bounce): its damping ratio set for the same restitution
    # as the Hunt-Crossley pair's (~0.63 at 4.2 m/s), e = exp(-zeta pi / sqrt(1 - zeta^2)) of a spring-damper
    e = 0.63
    zeta = -math.log(e) / math.hypot(math.pi, math.log(e))
    return Scene("ball", urdf, 0.6, (0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 0.0), mu=0.5, mass=m,
                 mujoco_solref=(0.02, zeta))


def incline_scene(theta_deg: float = 30.0, mu: float = 0.5) -> Scene:
    a, m = 0.2, 1.0
    i = m * a * a / 6
    urdf = (f'<robot name="box"><link name="box">{_inertial(m, i, i, i)}<collision><geometry>'
            f'<box size="{a} {a} {a}"/></geometry></collision></link></robot>')
    th = math.radians(theta_deg)
    normal = (math.sin(th), 0.0, math.cos(th))  # downhill is +x
    # the box rests on the plane through the origin, rotated by theta about y, its centre a/2 above it
    p0 = tuple(np.array(normal) * (a / 2))
    quat = (math.cos(th / 2), 0.0, math.sin(th / 2), 0.0)
    return Scene("incline", urdf, 1.0, p0, quat, normal=normal, mu=mu, dissipation=10.0, mass=m)


#: Go1 standing posture (rad) and gains of the joint springs
GO1_POSTURE = {"hip": 0.0, "thigh": 0.8, "calf": -1.5}


def go1_urdf(kd: float) -> str:
    """Go1 with its primitive collisions, no visuals, and joint damping ``kd`` (its URDF's Coulomb joint friction
    left out: Drake does not read it)."""
    text = Path(erd("go1_description/urdf/go1.urdf")).read_text()
    text = re.sub(r"<visual>.*?</visual>", "", text, flags=re.S)
    # its root link 'base' (1e-6 kg, an inertia with negative eigenvalues, welded to the trunk) made massless: MuJoCo
    # refuses the inertia, and the 1e-6 kg changes nothing
    text = re.sub(r'(<link name="base">\s*)<inertial>.*?</inertial>', r"\1", text, flags=re.S)
    return re.sub(r"<dynamics[^>]*/>", f'<dynamics damping="{kd}" friction="0"/>', text)


def quadruped_scene() -> Scene:
    import dynamics
    kd, kp = 2.0, 80.0
    urdf = go1_urdf(kd)
    joints = {f"{leg}_{part}_joint": value for leg in ("FR", "FL", "RR", "RL") for part, value in GO1_POSTURE.items()}
    model = dynamics.load_urdf(urdf.encode(), floating_base=True, strict_inertia=False)
    q = model.neutral()
    for name, value in joints.items():
        q[model.q_index[model.joint_names.index(name)]] = value
    foot = min(dynamics.frame_placement(model, q, f"{leg}_foot")[2, 3] for leg in ("FR", "FL", "RR", "RL"))
    height = -foot + 0.02  # the foot spheres (radius 0.02 m) touching z = 0
    return Scene("quadruped", urdf, 1.0, (0.0, 0.0, float(height)), (1.0, 0.0, 0.0, 0.0), joints, mu=0.8,
                 stiffness=2e4 * model.total_mass / 12, dissipation=2.0, kp=kp, kd=kd, mass=model.total_mass)


# -- MuJoCo -----------------------------------------------------------------------------------------------------
def mujoco_model(scene: Scene, dt: float):
    import mujoco
    spec = mujoco.MjSpec.from_string(scene.urdf)
    spec.compiler.discardvisual = True
    spec.worldbody.first_body().add_freejoint()
    n = np.array(scene.normal)
    plane = spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1])
    plane.quat = _quat_between((0.0, 0.0, 1.0), n)
    for g in spec.geoms:  # the scene's friction (sliding; MuJoCo's default torsional and rolling)
        g.friction = [scene.mu, 0.005, 0.0001]
        g.solref = list(scene.mujoco_solref)
        g.contype, g.conaffinity = 1, 0  # the robot touches the ground, not itself (as ours and Drake here)
    plane.contype, plane.conaffinity = 0, 1
    spec.option.timestep = dt
    m = spec.compile()
    for name, value in scene.joints0.items():  # PD springs to the posture
        j = m.joint(name)
        m.jnt_stiffness[j.id] = scene.kp
        m.qpos_spring[j.qposadr[0]] = value
    return m


def _quat_between(a, b) -> list[float]:
    """(w, x, y, z) rotating unit vector a onto unit vector b."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    c = np.cross(a, b)
    q = np.array([1.0 + a @ b, *c])
    return list(q / np.linalg.norm(q))


def mujoco_initial_state(scene: Scene, m) -> np.ndarray:
    """The scene's initial state in MuJoCo's model m, as its FULLPHYSICS state vector (time, then qpos, ...)."""
    import mujoco
    d = mujoco.MjData(m)
    d.qpos[:3], d.qpos[3:7] = scene.p0, scene.quat0
    for name, value in scene.joints0.items():
        d.qpos[m.joint(name).qposadr[0]] = value
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    x0 = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, x0, spec)
    return x0


def mujoco_runner(scene: Scene, dt: float) -> Callable[[], State]:
    import mujoco
    from mujoco import rollout
    m = mujoco_model(scene, dt)
    d = mujoco.MjData(m)
    x0 = mujoco_initial_state(scene, m)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    nstep = int(round(scene.duration / dt))

    def go() -> State:
        states, _ = rollout.rollout(m, d, x0, nstep=nstep)
        mujoco.mj_setState(m, d, states[0, -1], spec)
        return mujoco_state(m, d, scene)
    return go


def mujoco_state(m, d, scene: Scene) -> State:
    import mujoco
    mujoco.mj_forward(m, d)
    force = np.zeros(6)
    total = 0.0
    for i in range(d.ncon):
        mujoco.mj_contactForce(m, d, i, force)
        total += force[0]  # the normal component, in the contact frame
    joints = {name: float(d.qpos[m.joint(name).qposadr[0]]) for name in scene.joints0}
    w_body = d.qvel[3:6]
    R = d.xmat[m.jnt_bodyid[0]].reshape(3, 3)
    return State(d.qpos[:3].copy(), d.qpos[3:7].copy(), d.qvel[:3].copy(), R @ w_body, joints, total)


# -- Drake ------------------------------------------------------------------------------------------------------
class DrakeSim(NamedTuple):
    simulator: Any
    plant: Any
    body: Any


def drake_sim(scene: Scene, accuracy: float, integrator: str = "runge_kutta3") -> DrakeSim:
    from pydrake.geometry import CollisionFilterDeclaration, GeometrySet, HalfSpace
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, ContactModel
    from pydrake.multibody.tree import RevoluteSpring
    from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
    from pydrake.systems.framework import DiagramBuilder

    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
    Parser(plant).AddModelsFromString(_drake_urdf(scene.urdf), "urdf")
    props = _drake_material(scene)
    plant.RegisterCollisionGeometry(plant.world_body(), HalfSpace.MakePose(np.array(scene.normal), np.zeros(3)),
                                    HalfSpace(), "ground", props)
    inspector = scene_graph.model_inspector()
    for gid in inspector.GetAllGeometryIds():  # every robot geometry gets the scene's material
        if inspector.GetName(gid) != "ground" and inspector.GetProximityProperties(gid) is not None:
            scene_graph.AssignRole(plant.get_source_id(), gid, _drake_material(scene),
                                   _replace_role())
    robot = GeometrySet([g for g in inspector.GetAllGeometryIds() if inspector.GetName(g) != "ground"])
    scene_graph.collision_filter_manager().Apply(CollisionFilterDeclaration().ExcludeWithin(robot))  # no self-contact
    for name, value in scene.joints0.items():
        plant.AddForceElement(RevoluteSpring(plant.GetJointByName(name), value, scene.kp))
    plant.set_contact_model(ContactModel.kPoint)
    plant.set_stiction_tolerance(scene.stiction)
    plant.Finalize()
    simulator = Simulator(builder.Build())
    ResetIntegratorFromFlags(simulator, integrator, 0.01)
    simulator.get_mutable_integrator().set_target_accuracy(accuracy)
    body = plant.GetBodyByName(_root_link(scene.urdf))
    return DrakeSim(simulator, plant, body)


def _replace_role():
    from pydrake.geometry import RoleAssign
    return RoleAssign.kReplace


def _drake_material(scene: Scene):
    """Both geometries of a pair get 2 k: Drake combines stiffnesses in series (k1 k2 / (k1 + k2) = k), and
    equal dissipations and frictions combine to themselves."""
    from pydrake.geometry import AddContactMaterial, ProximityProperties
    from pydrake.multibody.plant import CoulombFriction
    props = ProximityProperties()
    AddContactMaterial(dissipation=scene.dissipation, point_stiffness=2 * scene.stiffness,
                       friction=CoulombFriction(scene.mu, scene.mu), properties=props)
    return props


def _drake_urdf(urdf: str) -> str:
    return urdf  # (primitives only: nothing for Drake's package map to find)


def _root_link(urdf: str) -> str:
    links = re.findall(r'<link name="([^"]+)"', urdf)
    children = set(re.findall(r'<child link="([^"]+)"', urdf))
    return next(name for name in links if name not in children)


def drake_runner(scene: Scene, accuracy: float, integrator: str = "runge_kutta3") -> Callable[[], State]:
    from pydrake.math import RigidTransform, RotationMatrix
    from pydrake.common.eigen_geometry import Quaternion
    sim = drake_sim(scene, accuracy, integrator)
    plant, body = sim.plant, sim.body

    def go() -> State:
        context = sim.simulator.get_mutable_context()
        context.SetTime(0.0)
        pc = plant.GetMyMutableContextFromRoot(context)
        plant.SetDefaultState(pc, pc.get_mutable_state())
        pose = RigidTransform(RotationMatrix(Quaternion(np.array(scene.quat0))), np.array(scene.p0))
        plant.SetFreeBodyPose(pc, body, pose)
        for name, value in scene.joints0.items():
            plant.GetJointByName(name).set_angle(pc, value)
        sim.simulator.Initialize()
        sim.simulator.AdvanceTo(scene.duration)
        return drake_state(sim, scene)
    return go


def drake_state(sim: DrakeSim, scene: Scene) -> State:
    plant, body = sim.plant, sim.body
    pc = plant.GetMyContextFromRoot(sim.simulator.get_context())
    X = plant.EvalBodyPoseInWorld(pc, body)
    V = plant.EvalBodySpatialVelocityInWorld(pc, body)
    results = plant.get_contact_results_output_port().Eval(pc)
    total = 0.0
    for i in range(results.num_point_pair_contacts()):
        info = results.point_pair_contact_info(i)
        total += abs(info.contact_force() @ info.point_pair().nhat_BA_W)
    joints = {name: float(plant.GetJointByName(name).get_angle(pc)) for name in scene.joints0}
    return State(X.translation().copy(), X.rotation().ToQuaternion().wxyz(), V.translational().copy(),
                 V.rotational().copy(), joints, total)


# -- ours -------------------------------------------------------------------------------------------------------
def ours_contact(scene: Scene, model=None):
    """The scene's Contact: its ground, and one material on every geometry (2 k each: two combine to k)."""
    import dynamics
    material = dynamics.Material(stiffness=2 * scene.stiffness, dissipation=scene.dissipation, mu_static=scene.mu,
                                 mu_dynamic=scene.mu, stiction_velocity=scene.stiction)
    return dynamics.Contact(ground=dynamics.Ground(normal=scene.normal), friction=material)


def ours_model(scene: Scene):
    import dynamics
    return dynamics.load_urdf(scene.urdf.encode(), floating_base=True, collision=True, strict_inertia=False)


def ours_initial(scene: Scene, model) -> tuple[np.ndarray, np.ndarray]:
    q0 = model.neutral()
    w, x, y, z = scene.quat0
    q0[:7] = (*scene.p0, x, y, z, w)
    for name, value in scene.joints0.items():
        q0[model.q_index[model.joint_names.index(name)]] = value
    return q0, np.zeros(model.nv)


def ours_torque(scene: Scene, model, q0):
    """The joint PD springs (kp on every joint but the free one; the damping is the URDF's)."""
    from dynamics.torques import PD
    if not scene.joints0:
        return None
    kp = np.full(model.nv, scene.kp)
    kp[:6] = 0.0
    return PD(q0, kp, 0.0)


def ours_runner(scene: Scene, rtol: float, integrator: str = "auto", dt=None) -> Callable[[], State]:
    """A simulate run of ours: adaptive at rtol (atol = rtol / 100), or a fixed-step integrator at dt."""
    import dynamics
    model = ours_model(scene)
    contact = ours_contact(scene)
    q0, v0 = ours_initial(scene, model)
    torque = ours_torque(scene, model, q0)

    def go() -> State:
        traj = dynamics.simulate(model, q0, v0, scene.duration, torque=torque, contact=contact, rtol=rtol,
                                 atol=rtol * 1e-2, integrator=integrator, dt=dt, error_estimate="none",
                                 sample_dt=scene.duration, progress=False)
        return ours_state(model, contact, traj.q[-1], traj.v[-1], scene)
    return go


def ours_state(model, contact, q, v, scene: Scene) -> State:
    import dynamics
    x, y, z, w = q[3:7]
    quat = np.array([w, x, y, z])
    R = _rotation(quat)
    _, details = dynamics.contact_forces(model, contact, q, v, details=True)
    joints = {name: float(q[model.q_index[model.joint_names.index(name)]]) for name in scene.joints0}
    return State(q[:3].copy(), quat, R @ v[:3], R @ v[3:6], joints, float(np.sum(details.normal_force)))


def _rotation(quat_wxyz) -> np.ndarray:
    w, x, y, z = quat_wxyz / np.linalg.norm(quat_wxyz)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


# -- runs, the round robin and the tables -----------------------------------------------------------------------
class Job(NamedTuple):
    scene: str
    tool: str       # "ours", "MuJoCo", "Drake"
    label: str      # "ours auto", "MuJoCo Euler", "Drake RK3"
    setting: str    # "rtol 1e-6", "dt 2e-3", "accuracy 1e-3"
    go: Callable[[], State]
    reference: bool = False  # the tool's tightest setting: its converged answer (timed like the others)


#: per scene: MuJoCo steps, Drake accuracies, our rtols, and each tool's tightest setting (its converged answer).
#: Drake's continuous-time RK3 takes ~20 s per simulated second on the incline at 1e-4 and a minute or more on Go1
#: at 1e-2 here, so its settings stop where a run costs minutes
#: our implicit_euler's steps (every scene): MuJoCo's default and two below it
IMPLICIT_DTS = (2e-3, 1e-3, 5e-4)
SETTINGS = {
    "ball": ((2e-3, 1e-3, 5e-4, 2e-4, 1e-4), (1e-1, 1e-2, 1e-3, 1e-4, 1e-5), (1e-3, 1e-4, 1e-5, 1e-6, 1e-7),
             (1e-5, 1e-7, 1e-10)),
    "incline": ((2e-3, 1e-3, 5e-4, 2e-4, 1e-4), (1e-1, 1e-2, 1e-3), (1e-3, 1e-4, 1e-5, 1e-6), (1e-5, 1e-4, 1e-9)),
    "quadruped": ((2e-3, 1e-3, 5e-4, 2e-4), (1e-1,), (1e-2, 1e-3, 1e-4, 1e-5), (1e-5, 1e-2, 1e-8)),
}


def jobs_for(scene: Scene, quick: bool, tools=("ours", "MuJoCo", "Drake")) -> list[Job]:
    dts, accuracies, rtols, (dt_ref, acc_ref, rtol_ref) = SETTINGS[scene.name]
    if quick:
        dts, accuracies, rtols = dts[:2], accuracies[:1], rtols[:2]
    out = [Job(scene.name, "MuJoCo", "MuJoCo Euler", f"dt {dt:.0e}", mujoco_runner(scene, dt)) for dt in dts]
    out.append(Job(scene.name, "MuJoCo", "MuJoCo Euler", f"dt {dt_ref:.0e}", mujoco_runner(scene, dt_ref), True))
    if "Drake" in tools:
        out += [Job(scene.name, "Drake", "Drake RK3", f"accuracy {a:.0e}", drake_runner(scene, a)) for a in accuracies]
        out.append(Job(scene.name, "Drake", "Drake RK3", f"accuracy {acc_ref:.0e}", drake_runner(scene, acc_ref),
                       True))
    out += [Job(scene.name, "ours", "ours auto", f"rtol {r:.0e}", ours_runner(scene, r)) for r in rtols]
    out += [Job(scene.name, "ours", "ours implicit_euler", f"dt {dt:.0e}",
                ours_runner(scene, 1e-3, "implicit_euler", dt)) for dt in (dts[:2] if quick else IMPLICIT_DTS)]
    out.append(Job(scene.name, "ours", "ours auto", f"rtol {rtol_ref:.0e}", ours_runner(scene, rtol_ref), True))
    return out


class Result(NamedTuple):
    job: Job
    seconds: float     # best wall time of one run over the rounds
    value: float       # the observable
    state: State


def round_robin(jobs: list[Job], repeat: int, log, first: list[tuple[State, float]]) -> list[Result]:
    """Every run once per round, ``repeat`` rounds, the best time of each; the references (answers, not
    contenders) keep their one untimed run (``first``: (state, seconds) per job)."""
    best = [t if job.reference else math.inf for job, (_, t) in zip(jobs, first)]
    # a run of a few ms is repeated within its turn (up to ~0.2 s a turn): one preemption on a shared machine is
    # worth more than such a run
    inner = [max(1, min(50, int(0.2 / max(t, 1e-4)))) for _, t in first]
    for r in range(repeat):
        for k, job in enumerate(jobs):
            if job.reference:
                continue
            for _ in range(inner[k]):
                t = time.perf_counter()
                job.go()
                best[k] = min(best[k], time.perf_counter() - t)
        log(f"  round {r + 1}/{repeat} done, load average {os.getloadavg()[0]:.2f}")
    return [Result(j, t, float("nan"), s) for j, t, (s, _) in zip(jobs, best, first)]


def evaluate(scene: Scene, results: list[Result]) -> list[Result]:
    return [r._replace(value=scene.observable(r.state)) for r in results]


def references(results: list[Result]) -> dict[str, float]:
    return {r.job.tool: r.value for r in results if r.job.reference}


def error(r: Result, refs: dict[str, float], scale: float) -> float:
    return abs(r.value - refs[r.job.tool]) / scale


def envelope(points):
    """The lower envelope (error, time) of a method's runs: for each error, the least time reaching it."""
    pts = sorted((e, t) for e, t in points if math.isfinite(e))
    out = []
    for e, t in sorted(pts, key=lambda p: p[0]):
        if not out or t < out[-1][1]:
            out.append((e, t))
    return out


def time_at(front, level):
    """Least time of a run whose error is <= level (None: no run reaches it)."""
    times = [t for e, t in front if e <= level]
    return min(times) if times else None


def scene_tables(scene: Scene, results: list[Result], log) -> list[str]:
    refs = references(results)
    scale = SCALES[scene.name](scene)
    lines = [f"### {scene.name}: {UNITS[scene.name]}", "",
             "converged: " + ", ".join(f"{tool} {v:.6g}" for tool, v in refs.items())
             + (f"; analytic {scene.analytic():.6g}" if scene.analytic() is not None else ""), "",
             "| time of X / time of ours at equal error | " + " | ".join(f"{e:.0e}" for e in ERROR_LEVELS) + " |",
             "|---|" + "---|" * len(ERROR_LEVELS)]
    runs = [r for r in results if not r.job.reference]
    ours = envelope([(error(r, refs, scale), r.seconds) for r in runs if r.job.tool == "ours"])
    for label in dict.fromkeys(r.job.label for r in runs if r.job.tool != "ours"):
        front = envelope([(error(r, refs, scale), r.seconds) for r in runs if r.job.label == label])
        cells = []
        for level in ERROR_LEVELS:
            a, b = time_at(front, level), time_at(ours, level)
            cells.append("-" if a is None or b is None else f"{a / b:.2g}x")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines += ["", f"| tool | setting | {UNITS[scene.name]} | error | wall s per simulated s |", "|---|---|---|---|---|"]
    for r in results:
        err = "(reference)" if r.job.reference else f"{error(r, refs, scale):.1e}"
        lines.append(f"| {r.job.label} | {r.job.setting} | {r.value:.6g} | {err} | {r.seconds / scene.duration:.4f} |")
    return lines


#: what an error is relative to: the drop height, the analytic slide distance, 1 (forces already over m g)
SCALES = {"ball": lambda s: s.p0[2], "incline": lambda s: s.analytic(), "quadruped": lambda s: 1.0}
SCENES = {"ball": ball_scene, "incline": incline_scene, "quadruped": quadruped_scene}


# -- contact on a robot touching nothing -------------------------------------------------------------------
def overhead(repeat: int, log) -> list[str]:
    """Go1 under its PD springs far above the ground for 1 s and 20 s: simulate with contact=Contact() (the broad
    phase finds nothing to touch at every evaluation) against no contact, timed alternately, best of many rounds
    (runs of a few ms). The difference splits into a fixed cost per call (resolving the Contact for the model)
    and a cost per step."""
    import dynamics
    scene = quadruped_scene()
    model = ours_model(scene)
    q0, v0 = ours_initial(scene, model)
    q0[2] = 3000.0
    torque = ours_torque(scene, model, q0)
    runs = {(d, name): contact for d in (1.0, 20.0) for name, contact in
            (("without contact", None), ("with contact (nothing touches)", dynamics.Contact()))}
    best = dict.fromkeys(runs, math.inf)
    steps = {}
    for r in range(10 * repeat + 1):  # (round 0 warms up: first calls, caches)
        for (duration, name), contact in runs.items():
            t = time.perf_counter()
            traj = dynamics.simulate(model, q0, v0, duration, torque=torque, contact=contact, error_estimate="none",
                                     progress=False)
            if r:
                best[duration, name] = min(best[duration, name], time.perf_counter() - t)
            steps[duration, name] = traj.report["steps"]
    log(f"  touching nothing: {best}")
    lines = ["### Contact on a robot touching nothing", "",
             "Go1 (19 collision primitives) under its PD springs 3 km above the ground, `auto` at rtol 1e-6, timed "
             f"alternately (best of {10 * repeat}).", "",
             "| duration | without contact | with contact (nothing touches) | steps | cost of contact |", "|---|---|---|---|---|"]
    for d in (1.0, 20.0):
        a, b = best[d, "without contact"], best[d, "with contact (nothing touches)"]
        lines.append(f"| {d:g} s | {a * 1e3:.1f} ms | {b * 1e3:.1f} ms | {steps[d, 'without contact']} / "
                     f"{steps[d, 'with contact (nothing touches)']} | {100 * (b / a - 1):+.0f} % |")
    return lines


def header(repeat: int, load_start) -> list[str]:
    import mujoco
    try:
        drake = f"Drake {importlib.metadata.version('drake')}"
    except importlib.metadata.PackageNotFoundError:
        drake = "Drake not installed (its runs left out)"
    versions = f"MuJoCo {mujoco.__version__}, {drake}"
    load_end = os.getloadavg()
    return [f"Machine: {os.cpu_count()} logical CPUs shared by several engineers; load average "
            f"{load_start[0]:.2f} at the start, {load_end[0]:.2f} at the end.  Python {sys.version.split()[0]}, "
            f"{versions}.  Every run timed in a round robin, best of {repeat} rounds."]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3, help="rounds of the round robin (best time of each run)")
    ap.add_argument("--quick", action="store_true", help="fewer settings, one round")
    ap.add_argument("--scenes", default=",".join(SCENES), help="comma-separated: " + ", ".join(SCENES))
    args = ap.parse_args(argv)
    repeat = 1 if args.quick else args.repeat
    # (the ball's 1 cm impact penetration is its scene's stiffness, not a mistake: the library's warning is noise here)
    warnings.filterwarnings("ignore", message="contact: the largest penetration")
    import logging
    try:
        import pydrake  # noqa: F401 - (its logger, "drake", exists once it is imported)
        logging.getLogger("drake").setLevel(logging.ERROR)  # (a half-space takes no part in deformable contact)
        tools = ("ours", "MuJoCo", "Drake")
    except ImportError:
        print("Drake not importable (pip install -e '.[bench]'): its runs are left out", flush=True)
        tools = ("ours", "MuJoCo")
    load_start = os.getloadavg()

    def log(s):
        print(s, flush=True)

    lines: list[str] = []
    for name in args.scenes.split(","):
        scene = SCENES[name]()
        log(f"{name}: building the runs")
        jobs = jobs_for(scene, args.quick, tools)
        first = []
        for job in jobs:  # once untimed: the first call of every run (every tool loads) before the round robin
            t = time.perf_counter()
            state = job.go()
            first.append((state, time.perf_counter() - t))
            log(f"  {job.label:<12} {job.setting:>16}: {scene.observable(state):.6g} in {first[-1][1]:.3f} s")
        results = evaluate(scene, round_robin(jobs, repeat, log, first))
        lines += scene_tables(scene, results, log) + [""]
    lines += overhead(repeat, log) + [""]
    text = "\n".join(["# Contact (`python -m benchmarks.contact`)", ""] + header(repeat, load_start) + [""] + lines)
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "contact.md").write_text(text + "\n")
    print("\n" + text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
