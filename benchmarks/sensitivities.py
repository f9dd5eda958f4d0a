"""Simulation with derivatives: ``python -m benchmarks.sensitivities [--quick]``.

Section "radau": wall time of Radau with the robot's Jacobian assembled from its parts' derivatives
(:mod:`dynamics.simulation.jacobian`, the default) against the same solver on the finite-difference Jacobian of
the whole right-hand side (what it used before: the problem class without a ``jacobian``), on the stiff suite
(damped chains, joint damping 1e3: time constants ~10 us), a stiff PD on Panda and (without --quick) a contact
scene with nv >= 20, Talos standing on box soles (nv 38, rtol 1e-6).  Both runs alternate in the
same process, after a warm-up that compiles both; the ratio is FD / analytical (> 1: faster).  The final states
of the two agree to the tolerance (the column "|dx|").

Section "sensitivities": the wall time of one ``simulate(..., sensitivities=True)`` (dx(T)/dx0, 2 nv columns)
against 2 nv + 1 plain simulations (forward differences of x0: what a shooting method does without
sensitivities), rk45 and radau, the same tolerance.
"""

import argparse
import importlib
import os
import sys
import time

import numpy as np
from numba import njit

import dynamics
from dynamics.contact.resolve import contact_model
from dynamics.control.validation import make_source
from dynamics.simulation.jacobian import robot_jacobian
from dynamics.simulation.problem import RobotProblem, rhs, robot_problem
from dynamics.simulation.solvers import new_stats
from dynamics.simulation.solvers.linalg import fd_jacobian
from dynamics.torques import PD

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests"))
from robots import chain_urdf, erd  # noqa: E402

SIM = importlib.import_module("dynamics.simulation.simulate")


class FDJacobianProblem(RobotProblem):
    """The robot problem without its ``jacobian``: Radau falls back to differencing the right-hand side."""

    jacobian = None


def _fd_variant(fd):
    """simulate() builds FDJacobianProblem when ``fd`` (a benchmark-only switch of the problem's class)."""
    if not hasattr(SIM, "_robot_problem_original"):
        SIM._robot_problem_original = SIM.robot_problem
    orig = SIM._robot_problem_original
    SIM.robot_problem = (lambda *a: FDJacobianProblem(*orig(*a))) if fd else orig


def stiff_cases(quick):
    sizes = (6, 12) if quick else (6, 12, 24)
    out = []
    for n in sizes:
        m = dynamics.load_urdf(chain_urdf(n, damping=1e3))
        out.append((f"chain{n} damping 1e3", m, np.linspace(0.2, 1.2, n), np.ones(n), 0.5, None, None))
    panda = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")
    q0 = panda.neutral() + 0.1
    target = q0 + 0.2
    pd = PD(target, 1e4, 1e3, tau_ff=dynamics.gravity_torques(panda, target))
    out.append(("Panda stiff PD (kp 1e4, kd 1e3)", panda, q0, np.zeros(panda.nv), 0.5, pd, None))
    if not quick:
        out.append(talos_standing())
    return out


def talos_standing():
    """Talos (every joint, floating base) standing on two box soles under joint PD with gravity compensation:
    a contact scene with nv >= 20 (as tests/test_contact_humanoid.py, without its locked upper body)."""
    soles, sole = ["left_sole_link", "right_sole_link"], (0.2, 0.1, 0.02)
    model = dynamics.load_urdf(erd("talos_data/robots/talos_reduced.urdf"), floating_base=True,
                               strict_inertia=False)
    q = model.neutral().copy()
    for side in ("left", "right"):
        for j, angle in ((3, -0.411354), (4, 0.859395), (5, -0.448041)):  # half sitting
            q[model.q_index[model.joint_names.index(f"leg_{side}_{j}_joint")]] = angle
    weight = float(np.sum(model.tree.mass)) * 9.81
    pose = np.eye(4)
    pose[2, 3] = sole[2] / 2
    contact = dynamics.Contact(geometries=[dynamics.Box(f, sole, pose) for f in soles])
    k = weight / contact.friction.penetration_allowance  # the default stiffness of each contact point
    q[2] = -dynamics.frame_placement(model, q, soles[0])[2, 3] - weight / (8 * k)  # 8 corners share the weight
    g = dynamics.gravity_torques(model, q)
    J = [dynamics.frame_jacobian(model, q, f) for f in soles]
    w = np.linalg.lstsq(np.hstack([Jf[:, :6].T for Jf in J]), g[:6], rcond=None)[0]
    n = model.nv - 6
    pd = PD(q.copy(), np.r_[np.zeros(6), np.full(n, 3000.0)], np.r_[np.zeros(6), np.full(n, 100.0)],
            tau_ff=g - J[0].T @ w[:6] - J[1].T @ w[6:])
    return ("Talos standing, contact (rtol 1e-6)", model, q, np.zeros(model.nv), 0.5, pd, contact)


def _wall(model, q0, v0, T, torque, fd, reps, contact=None, **kw):
    _fd_variant(fd)
    best, tr = np.inf, None
    if contact is not None:
        kw.update(contact=contact, rtol=1e-6, atol=1e-8)
    for _ in range(reps):
        tr = dynamics.simulate(model, q0, v0, T, torque=torque, integrator="radau", error_estimate="none",
                               outputs=("q", "v"), **kw)
        best = min(best, tr.report["wall_time_s"])
    _fd_variant(False)
    return best, tr


@njit
def _jacobians(p, z, f0, J, st, ne, fd, reps):
    n = z.shape[0]
    for _ in range(reps):
        if fd:
            fd_jacobian(p, 0.0, z, f0, np.zeros(n), ne, J, st[0])
        else:
            robot_jacobian(p, 0.0, z, f0, z, ne, J, st[0])


def one_jacobian_us(model, q0, v0, torque, contact=None):
    """Microseconds of one right-hand-side Jacobian: (analytical, finite differences), alternately timed."""
    s = SIM._settings(model, q0, v0, 1.0, "radau", 1e-6, 1e-8, None, None, None, 10, "none", ("q",), [], None,
                      False, contact)
    cm = None if contact is None else contact_model(s.contact, model, 1)
    p = robot_problem(model, SIM._passive(model, s, None, 1e4, 100.0, 1e-3), make_source(model, torque), s.q0,
                      np.zeros(1), (), cm)
    n = 2 * model.nv + 2 + (cm is not None)
    z, f0, J, st = np.zeros(n), np.zeros(n), np.zeros((n, n)), new_stats()
    z[model.nv:2 * model.nv] = v0
    rhs(p, 0.0, z, f0)
    out = [np.inf, np.inf]
    for _ in range(5):
        for fd in (0, 1):
            t = time.perf_counter()
            _jacobians(p, z, f0, J, st, 2 * model.nv, fd, 200)
            out[fd] = min(out[fd], (time.perf_counter() - t) / 200 * 1e6)
    return out


def radau_section(quick):
    rows = ["| case | nv | steps | Jacobians | one Jacobian: analytical / FD (us) | run, analytical (s) | "
            "run, finite differences (s) | ratio FD/analytical | \\|dx\\| |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    reps = 1 if quick else 3
    for name, m, q0, v0, T, torque, contact in stiff_cases(quick):
        for fd in (False, True):  # warm-up: compile both
            _wall(m, q0, v0, min(T, 0.01), torque, fd, 1, contact)
        wa, wf = [], []
        for _ in range(reps):  # alternately
            a, ta = _wall(m, q0, v0, T, torque, False, 1, contact)
            f, tf = _wall(m, q0, v0, T, torque, True, 1, contact)
            wa.append(a)
            wf.append(f)
        dx = max(np.abs(ta.q[-1] - tf.q[-1]).max(), np.abs(ta.v[-1] - tf.v[-1]).max())
        ja, jf = one_jacobian_us(m, q0, v0, torque, contact)
        rows.append(f"| {name} | {m.nv} | {ta.report['steps']} | {ta.report['jacobian_evals']} | "
                    f"{ja:.0f} / {jf:.0f} ({jf / ja:.1f}x) | {min(wa):.3f} | "
                    f"{min(wf):.3f} | {min(wf) / min(wa):.2f} | {dx:.1e} |")
        print(rows[-1], flush=True)
    return rows


def sensitivity_section(quick):
    rows = ["| case | integrator | nv | one run (s) | with sensitivities (s) | 2 nv + 1 runs (s) | ratio | "
            "error estimate of S |",
            "|---|---|---:|---:|---:|---:|---:|---:|"]
    two_r = dynamics.load_urdf(dynamics.robots.path("planar_2r"))
    panda = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")
    pq0 = panda.neutral() + 0.1
    cases = [("double pendulum, PD", two_r, np.array([0.3, 0.2]), np.array([0.0, 1.5]), 2.0,
              PD([0.5, -0.3], 8.0, 0.5)),
             ("Panda, PD", panda, pq0, np.zeros(panda.nv), 0.5 if quick else 1.0,
              PD(pq0 + 0.2, 200.0, 20.0, tau_ff=dynamics.gravity_torques(panda, pq0 + 0.2)))]
    for name, m, q0, v0, T, pd in cases:
        for integ in ("rk45", "radau"):
            kw = dict(torque=pd, integrator=integ, rtol=1e-8, atol=1e-10, outputs=("q", "v"))
            dynamics.simulate(m, q0, v0, 0.01, sensitivities=True, error_estimate="none", **kw)  # compile
            dynamics.simulate(m, q0, v0, 0.01, error_estimate="none", **kw)
            tr = dynamics.simulate(m, q0, v0, T, sensitivities=True, **kw)
            ts = tr.report["wall_time_s"]
            one = np.inf
            t1 = time.perf_counter()
            for k in range(2 * m.nv + 1):
                dq = np.zeros(m.nv)
                dq[k % m.nv] = 1e-7 if k else 0.0
                r = dynamics.simulate(m, q0 + dq, v0, T, error_estimate="none", **kw)
                one = min(one, r.report["wall_time_s"])
            tfd = time.perf_counter() - t1
            rows.append(f"| {name} | {integ} | {m.nv} | {one:.3f} | {ts:.3f} | {tfd:.3f} | {tfd / ts:.1f} | "
                        f"{tr.report['sensitivities']['error_estimate']:.1e} |")
            print(rows[-1], flush=True)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--section", choices=("radau", "sensitivities", "all"), default="all")
    a = ap.parse_args(argv)
    out = []
    if a.section in ("radau", "all"):
        out += ["## radau: analytical against finite-difference Jacobian", ""] + radau_section(a.quick) + [""]
    if a.section in ("sensitivities", "all"):
        out += ["## sensitivities: one run against 2 nv + 1 runs", ""] + sensitivity_section(a.quick)
    print("\n".join(out))


if __name__ == "__main__":
    main()
