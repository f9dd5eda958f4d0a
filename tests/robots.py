"""Robots for the tests: example-robot-data URDFs (never copied into the repo) and random trees."""

import importlib.metadata
import os
from functools import lru_cache

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUR_ROBOTS = os.path.join(REPO, "robots")


@lru_cache(maxsize=1)
def erd_root() -> str:
    """The robots/ folder installed by the example-robot-data package."""
    dist = importlib.metadata.distribution("example-robot-data")
    for rel in ("cmeel.prefix/share/example-robot-data/robots", "share/example-robot-data/robots"):
        path = str(dist.locate_file(rel))
        if os.path.isdir(path):
            return path
    raise RuntimeError("example-robot-data is installed but its robots/ folder was not found")


def erd(rel: str) -> str:
    return os.path.join(erd_root(), rel)


def erd_urdfs():
    """Every URDF file shipped by example-robot-data, as paths relative to its robots/ folder."""
    root = erd_root()
    out = []
    for dirpath, _, files in os.walk(root):
        for f in files:
            if f.endswith(".urdf"):
                out.append(os.path.relpath(os.path.join(dirpath, f), root))
    return sorted(out)


def random_state(model, rng, scale=1.0):
    """(q, v, a): unit quaternions, a planar joint's (cos, sin) of a random angle, angles in [-pi, pi]."""
    q = rng.uniform(-np.pi, np.pi, model.nq)
    for jtype, k in zip(model.joint_types, model.q_index):
        if jtype == "floating":
            q[k:k + 3] = rng.normal(size=3)
            quat = rng.normal(size=4)
            q[k + 3:k + 7] = quat / np.linalg.norm(quat)
        elif jtype == "spherical":
            quat = rng.normal(size=4)
            q[k:k + 4] = quat / np.linalg.norm(quat)
        elif jtype == "planar":
            t = rng.uniform(-np.pi, np.pi)
            q[k:k + 4] = [*rng.normal(size=2), np.cos(t), np.sin(t)]
        elif jtype == "prismatic":
            q[k] = rng.uniform(-0.5, 0.5)
    return q, scale * rng.normal(size=model.nv), scale * rng.normal(size=model.nv)


def _fmt(x):
    return " ".join(f"{v:.17g}" for v in x)


def random_inertia(rng, scale=1.0):
    """A physical rotational inertia about the centre of mass: random principal moments obeying the
    triangle inequality, rotated randomly."""
    a, b = rng.uniform(0.2, 1.0, 2) * scale
    c = rng.uniform(abs(a - b), a + b)
    Qm, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return Qm @ np.diag([a, b, c]) @ Qm.T


def random_urdf(rng, n_links=8, *, types=("revolute", "continuous", "prismatic", "fixed"), branching=0.4,
                floating_joint=False, mass_range=(0.5, 5.0), name="random"):
    """URDF text of a random tree: random joint and inertial origins (xyz and rpy), non-unit axes,
    branching, every joint type in ``types`` (:data:`ALL_TYPES`: the planar and spherical joints too, a planar
    joint's axis z half the time, Pinocchio's only one).  ``floating_joint`` puts a URDF floating joint at the
    root."""
    links = []
    joints = []
    parent_of = []

    def link_xml(i):
        m = rng.uniform(*mass_range)
        I = random_inertia(rng, scale=m * 0.05)
        return (f'<link name="l{i}"><inertial><origin xyz="{_fmt(rng.uniform(-0.3, 0.3, 3))}" '
                f'rpy="{_fmt(rng.uniform(-np.pi, np.pi, 3))}"/><mass value="{m:.17g}"/>'
                f'<inertia ixx="{I[0,0]:.17g}" ixy="{I[0,1]:.17g}" ixz="{I[0,2]:.17g}" iyy="{I[1,1]:.17g}" '
                f'iyz="{I[1,2]:.17g}" izz="{I[2,2]:.17g}"/></inertial></link>')

    start = 0
    if floating_joint:
        links.append('<link name="world"/>')
        joints.append('<joint name="float" type="floating"><parent link="world"/><child link="l0"/></joint>')
    links.append(link_xml(0))
    for i in range(1, n_links):
        parent = i - 1 if rng.uniform() > branching else int(rng.integers(start, i))
        parent_of.append(parent)
        t = types[int(rng.integers(len(types)))]
        axis = rng.normal(size=3)
        axis *= rng.uniform(0.3, 3.0) / np.linalg.norm(axis)  # not unit length
        if t == "planar" and rng.uniform() < 0.5:
            axis = np.array([0.0, 0.0, rng.uniform(0.3, 3.0)])
        limit = ('<limit lower="-2" upper="2" effort="50" velocity="3"/>' if t in ("revolute", "prismatic")
                 else "")
        joints.append(f'<joint name="j{i}" type="{t}"><parent link="l{parent}"/><child link="l{i}"/>'
                      f'<origin xyz="{_fmt(rng.uniform(-0.5, 0.5, 3))}" rpy="{_fmt(rng.uniform(-np.pi, np.pi, 3))}"/>'
                      f'<axis xyz="{_fmt(axis)}"/>{limit}</joint>')
        links.append(link_xml(i))
    return f'<robot name="{name}">' + "".join(links) + "".join(joints) + "</robot>"


#: every joint type the URDF reader knows, spherical included (random_urdf's ``types``)
ALL_TYPES = ("revolute", "continuous", "prismatic", "fixed", "planar", "spherical")


def chain_urdf(n, *, length=0.2, mass=1.0, inertia=1e-3, damping=0.0, name=None, axis="0 1 0"):
    """A serial chain of n revolute links of equal mass, swinging about y (a pendulum chain)."""
    parts = [f'<robot name="{name or f"chain{n}"}"><link name="base"/>']
    for i in range(n):
        parts.append(
            f'<link name="link{i}"><inertial><origin xyz="0 0 {-length / 2}"/><mass value="{mass}"/>'
            f'<inertia ixx="{inertia}" ixy="0" ixz="0" iyy="{inertia}" iyz="0" izz="{inertia}"/></inertial></link>')
        parent = "base" if i == 0 else f"link{i - 1}"
        z = 0.0 if i == 0 else -length
        parts.append(
            f'<joint name="joint{i}" type="revolute"><parent link="{parent}"/><child link="link{i}"/>'
            f'<origin xyz="0 0 {z}"/><axis xyz="{axis}"/><limit lower="-3.14" upper="3.14" effort="100" '
            f'velocity="10"/><dynamics damping="{damping}" friction="0"/></joint>')
    parts.append("</robot>")
    return "".join(parts)


def vector_fd(f, x, step):
    """Central differences of f at x, column k along e_k (a plain vector space: v, or q of 1-dof joints)."""
    cols = []
    for k in range(x.shape[0]):
        e = np.zeros_like(x)
        e[k] = step
        cols.append((f(x + e) - f(x - e)) / (2 * step))
    return np.array(cols).T
