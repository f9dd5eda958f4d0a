"""Scene benchmarks (issue 5): `python -m benchmarks.scene`.

What leaving things out saves, measured in one run on the same machine, as ratios (reduced / full: below 1.0
is a saving):

* skipped terms: gravity torques (v = a = 0) and zero-velocity inverse and forward dynamics against the full
  computation, on batches of states, for a quadruped (Solo-12) and a humanoid (Talos, 50 dof);
* locking: Talos with arms, grippers and head locked (20 dof left) against the full 50-dof model;
* pruning and skipped meshes: loading Talos (15 fixed joints merged, massless frames pruned, no meshes)
  against yourdfpy's default load (scene graph, meshes read from disk), and a URDF with 80 references to
  missing mesh files against the same URDF without them.

Timings are the best of --repeat runs.  The table is printed and written to benchmarks/out/scene.md.
"""

import argparse
from pathlib import Path

import numpy as np

import dynamics
from benchmarks.core import best_time, erd_robots_dir

OUT = Path(__file__).resolve().parent / "out" / "scene.md"


def states(model, B, rng):
    Q = rng.uniform(-1, 1, (B, model.nq))
    for k in model.quaternion_starts:
        Q[:, k:k + 4] /= np.linalg.norm(Q[:, k:k + 4], axis=1, keepdims=True)
    return Q, rng.normal(size=(B, model.nv)), rng.normal(size=(B, model.nv))


def per_state(fn, B, repeat):
    fn()
    return best_time(fn, repeat) / B


def paired(reduced, full, B, repeat):
    """Best per-state times of two calls measured alternately, so both see the same machine load."""
    reduced(), full()
    tr = tf = float("inf")
    for _ in range(repeat):
        tr = min(tr, best_time(reduced, 1) / B)
        tf = min(tf, best_time(full, 1) / B)
    return tr, tf


def skipped_rows(name, model, B, repeat, rng):
    Q, V, A = states(model, B, rng)
    Z = np.zeros_like(V)

    def full_id():
        return dynamics.inverse_dynamics(model, Q, V, A)

    def full_fd():
        return dynamics.forward_dynamics(model, Q, V, A)

    cases = [
        ("gravity torques (v = a = 0) vs full ID", lambda: dynamics.gravity_torques(model, Q), full_id, 0.5),
        ("ID at v = 0 vs full ID", lambda: dynamics.inverse_dynamics(model, Q, Z, A), full_id, 0.8),
        ("bias forces (a = 0) vs full ID", lambda: dynamics.bias_forces(model, Q, V), full_id, None),
        ("FD at v = 0 vs full FD", lambda: dynamics.forward_dynamics(model, Q, Z, A), full_fd, None),
    ]
    return [(name, what, *paired(fn, ref, B, repeat), target) for what, fn, ref, target in cases]


def lock_rows(model, B, repeat, rng):
    Q, V, A = states(model, B, rng)
    lock = {n: 0.0 for n in model.joint_names if n.startswith(("arm_", "gripper_", "head_"))}
    reduced = dynamics.lock_joints(model, lock)
    keep = [model.v_index[i] + k for i, n in enumerate(model.joint_names) if n not in lock
            for k in range(model.nv_joint[i])]
    keep_q = [model.q_index[i] + k for i, n in enumerate(model.joint_names) if n not in lock
              for k in range(model.nq_joint[i])]
    Qr, Vr, Ar = (np.ascontiguousarray(X[:, idx]) for X, idx in ((Q, keep_q), (V, keep), (A, keep)))
    name = f"Talos {model.nv} -> {reduced.nv} dof"
    cases = [
        ("locked arms, grippers, head: ID", lambda: dynamics.inverse_dynamics(reduced, Qr, Vr, Ar),
         lambda: dynamics.inverse_dynamics(model, Q, V, A)),
        ("locked arms, grippers, head: FD", lambda: dynamics.forward_dynamics(reduced, Qr, Vr, Ar),
         lambda: dynamics.forward_dynamics(model, Q, V, A)),
        ("locked arms, grippers, head: M", lambda: dynamics.mass_matrix(reduced, Qr),
         lambda: dynamics.mass_matrix(model, Q)),
    ]
    return [(name, what, *paired(fn, ref, B, repeat), None) for what, fn, ref in cases]


def load_rows(talos_path, repeat):
    import yourdfpy

    ours = best_time(lambda: dynamics.load_urdf(talos_path, floating_base=True), repeat)
    theirs = best_time(lambda: yourdfpy.URDF.load(talos_path), max(1, repeat // 3))
    base = ('<robot name="m"><link name="a"/><link name="b"><inertial><mass value="1"/>'
            '<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>{}</link>'
            '<joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint></robot>')
    meshes = "".join(f'<visual><geometry><mesh filename="package://gone/m{i}.stl"/></geometry></visual>'
                     f'<collision><geometry><mesh filename="/missing/c{i}.dae"/></geometry></collision>' for i in range(40))
    with_meshes = best_time(lambda: dynamics.load_urdf(base.format(meshes)), repeat * 20)
    without = best_time(lambda: dynamics.load_urdf(base.format("")), repeat * 20)
    return [
        ("Talos URDF", "load_urdf (no meshes, fixed joints merged) vs yourdfpy.URDF.load defaults", ours, theirs, None),
        ("80 missing mesh files", "load_urdf with vs without the mesh references", with_meshes, without, None),
    ]


def table(rows):
    lines = ["| robot | what | reduced | full | ratio | target |", "|---|---|---:|---:|---:|---:|"]
    for robot, what, t, ref, target in rows:
        unit = (1e3, "ms") if ref > 1e-3 else (1e6, "us")
        lines.append(f"| {robot} | {what} | {t * unit[0]:.2f} {unit[1]} | {ref * unit[0]:.2f} {unit[1]} | "
                     f"{t / ref:.2f} | {'<= %.1f' % target if target else ''} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batch", type=int, default=10_000)
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(0)
    root = erd_robots_dir()
    solo = dynamics.load_urdf(root / "solo_description/robots/solo12.urdf", floating_base=True)
    talos_path = root / "talos_data/robots/talos_full_v2.urdf"
    talos = dynamics.load_urdf(talos_path, floating_base=True)
    rows = (skipped_rows("Solo-12 (18 dof)", solo, args.batch, args.repeat, rng)
            + skipped_rows("Talos (50 dof)", talos, args.batch, args.repeat, rng)
            + lock_rows(talos, args.batch, args.repeat, rng)
            + load_rows(str(talos_path), args.repeat))
    text = table(rows)
    print(text)
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(text + "\n")


if __name__ == "__main__":
    main()
