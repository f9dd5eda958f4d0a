"""Narrow phase per pair: `python -m benchmarks.narrow_phase [--pairs N] [--repeat R]`.

For each kind pair, N pairs at the seeded random poses of tests/test_narrow_phase_core.py (about half of them
touching), all static, and the time of one broad + narrow phase over them divided by N: microseconds per pair,
touching or not.

* **core**: ``_core.collide_bench``, ``core::contact::collide`` in a C++ loop (the world poses computed once);
* **MuJoCo** (if ``import mujoco`` works): the same primitives, each on a free body at the same pose (a plane on
  the world body), every pair an explicit ``<pair>`` and automatic collisions off, ``mj_collision`` from a
  Python loop.  MuJoCo does more per contact (its contact frame, margins, solver parameters) and collides
  cylinders with spheres, capsules and boxes by general convex collision (MPR/GJK), exactly; ours treats them
  as capsules.  It has no point (a sphere of radius 1e-6 here) and does not collide plane with plane.

Best of --repeat rounds.  The table is printed and written to benchmarks/out/narrow_phase.md.
"""

import argparse
import time
from pathlib import Path

import numpy as np

import dynamics
from dynamics import _core
from dynamics.contact.scene import CAPSULE, CYLINDER, PLANE, POINT, SPHERE
from tests.test_narrow_phase_core import NAMES, PAIRS, Geometries, random_pair

OUT = Path(__file__).resolve().parent / "out" / "narrow_phase.md"


def scene_of(ka, kb, N):
    rng = np.random.default_rng(1000 + 10 * ka + kb)
    G = Geometries()
    for _ in range(N):
        random_pair(G, ka, kb, rng)
    return G.scene(8 * N)


def core_time(model, scene, q, repeats):
    seconds, n = _core.collide_bench(model.core, *scene.arrays, q, scene.max_contacts, repeats)
    return seconds, n


def quaternion(R):
    """MuJoCo's (w, x, y, z) of a rotation matrix."""
    import mujoco

    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, float).ravel())
    return q


def numbers(x):
    return " ".join(repr(float(v)) for v in x)


def mujoco_geom(scene, g, name):
    """MJCF of geometry g (MuJoCo's sizes are half lengths)."""
    k, s = scene.kind[g], scene.size[g]
    contact = 'contype="0" conaffinity="0"'
    if k == PLANE:
        return f'<geom name="{name}" type="plane" size="0 0 1" {contact}/>'
    if k in (SPHERE, POINT):
        return f'<geom name="{name}" type="sphere" size="{max(s[0], 1e-6)}" {contact}/>'
    if k in (CAPSULE, CYLINDER):
        kind = "capsule" if k == CAPSULE else "cylinder"
        return f'<geom name="{name}" type="{kind}" size="{s[0]} {0.5 * s[1]}" {contact}/>'
    return f'<geom name="{name}" type="box" size="{0.5 * s[0]} {0.5 * s[1]} {0.5 * s[2]}" {contact}/>'


def mujoco_model(scene):
    """Every geometry on a free body at its pose (a plane on the world body), every pair explicit."""
    import mujoco

    world, bodies, qpos = [], [], []
    for g in range(len(scene.kind)):
        pose = f'pos="{numbers(scene.p[g])}" quat="{numbers(quaternion(scene.R[g]))}"'
        if scene.kind[g] == PLANE:
            world.append(mujoco_geom(scene, g, f"g{g}").replace("<geom ", f"<geom {pose} "))
        else:
            bodies.append(f'<body name="b{g}"><freejoint/><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>'
                          f'{mujoco_geom(scene, g, f"g{g}")}</body>')
            qpos.append(np.concatenate([scene.p[g], quaternion(scene.R[g])]))
    pairs = "".join(f'<pair geom1="g{a}" geom2="g{b}"/>' for a, b in zip(scene.pair_a, scene.pair_b))
    xml = (f'<mujoco><option><flag gravity="disable"/></option><worldbody>{"".join(world)}{"".join(bodies)}'
           f'</worldbody><contact>{pairs}</contact></mujoco>')
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    if qpos:
        d.qpos[:] = np.concatenate(qpos)
    mujoco.mj_kinematics(m, d)
    return m, d


def mujoco_time(m, d, repeats):
    import mujoco

    mujoco.mj_collision(m, d)
    t0 = time.perf_counter()
    for _ in range(repeats):
        mujoco.mj_collision(m, d)
    return (time.perf_counter() - t0) / repeats, d.ncon


def best(f, rounds):
    return min(f() for _ in range(rounds))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=400, help="pairs of each kind pair")
    ap.add_argument("--repeat", type=int, default=7, help="rounds (the best is kept: the machine may be shared)")
    ap.add_argument("--calls", type=int, default=200, help="calls per round")
    args = ap.parse_args()
    try:
        import mujoco  # noqa: F401
        have_mujoco = True
    except ImportError:
        have_mujoco = False
        print("MuJoCo not importable: its column is left out")
    model = dynamics.load_urdf("planar_2r")
    q = model.neutral()
    N = args.pairs
    lines = [f"microseconds per pair ({N} pairs per kind pair, best of {args.repeat} x {args.calls} calls)", "",
             f"| {'pair':<18} | contacts | core  | MuJoCo | contacts | core/MuJoCo |",
             f"|{'-' * 20}|---------:|------:|-------:|---------:|------------:|"]
    print("\n".join(lines), flush=True)
    for ka, kb in PAIRS:
        scene = scene_of(ka, kb, N)
        c = best(lambda: core_time(model, scene, q, args.calls)[0], args.repeat) / N * 1e6
        n = core_time(model, scene, q, 1)[1]
        row = f"| {NAMES[ka] + '-' + NAMES[kb]:<18} | {n:8d} | {c:5.3f} |"
        if have_mujoco and not ka == kb == PLANE:
            m, d = mujoco_model(scene)
            mj = best(lambda: mujoco_time(m, d, args.calls)[0], args.repeat) / N * 1e6
            row += f" {mj:6.3f} | {mujoco_time(m, d, 1)[1]:8d} | {c / mj:11.2f} |"
        else:
            row += f" {'-':>6} | {'-':>8} | {'-':>11} |"
        lines.append(row)
        print(row, flush=True)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
