"""Simulations whose results must not change when the simulation's machinery changes (issue 24's proof): the
stiff suite, the four-bar and the Panda PD run, plus one run per compiled torque kind.

``python -m tests.sim_golden`` records a digest of every case's numbers (SHA-256 of the float64 bytes, with
the shape and the last row to show a difference) into tests/data/sim_golden.json (run it on the code before a
change); tests/test_simulate_bit_identical.py runs the cases again and compares bit for bit.  The
recorded numbers are not a reference of correctness (the other tests are): they pin down that a change of how
the solvers reach the problem changed no arithmetic.
"""

import functools
import hashlib
import json
import os
import sys

import numpy as np

import dynamics
from dynamics.torques import PD, ComputedTorque, Table, Target

HERE = os.path.dirname(os.path.abspath(__file__))
GOLDEN = os.path.join(HERE, "data", "sim_golden.json")
sys.path.insert(0, HERE)
from robots import chain_urdf, erd  # noqa: E402

REPO = os.path.dirname(HERE)
#: the report's numbers that a change of machinery must not move (wall times excluded)
REPORT_KEYS = ("t_final", "steps", "rejected_steps", "rhs_evals", "jacobian_evals", "lu_decompositions",
               "error_estimate", "energy_drift", "work_torque", "work_passive")


def _panda():
    return dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")


def _panda_pd(model):
    rng = np.random.default_rng(3)
    target = np.zeros(model.nq) + rng.uniform(-0.3, 0.3, model.nq)  # (zeros: neutral() as it was recorded)
    return PD(target, 200.0, 20.0, tau_ff=dynamics.gravity_torques(model, target))


@functools.lru_cache(maxsize=1)
def cases():
    """name -> (a function returning the Trajectory)."""
    stiff = dynamics.load_urdf(chain_urdf(6, damping=1e3))
    stiff_q0 = np.full(stiff.nq, 0.3)
    four_bar = dynamics.load_urdf(os.path.join(REPO, "robots", "four_bar.urdf"))
    fb_q0 = dynamics.assemble(four_bar, np.array([0.2, 0.5, 1.5]), fixed=["theta1"])
    fb_v0 = dynamics.project_velocity(four_bar, fb_q0, np.array([1.0, 0.0, 0.0]))
    two_r = dynamics.load_urdf(os.path.join(REPO, "robots", "planar_2r.urdf"))
    panda = _panda()
    pq0 = np.zeros(panda.nq) + 0.1  # neutral() before it kept joint 4 within its limits, as recorded
    t = np.linspace(0.0, 0.5, 6)
    ref_q = np.stack([0.3 * np.sin(t), 0.2 * np.cos(t)], 1)
    ref_v = np.stack([0.3 * np.cos(t), -0.2 * np.sin(t)], 1)
    ref_a = np.stack([-0.3 * np.sin(t), -0.2 * np.cos(t)], 1)
    sim = dynamics.simulate
    return {
        "stiff_auto": lambda: sim(stiff, stiff_q0, np.zeros(stiff.nv), 0.05),
        "stiff_radau": lambda: sim(stiff, stiff_q0, np.zeros(stiff.nv), 0.05, integrator="radau"),
        "stiff_rk45": lambda: sim(stiff, stiff_q0, np.zeros(stiff.nv), 0.002, integrator="rk45"),
        "four_bar_auto": lambda: sim(four_bar, fb_q0, fb_v0, 0.5, outputs=("q", "v", "tau", "lambda")),
        "four_bar_rk4_project": lambda: sim(four_bar, fb_q0, fb_v0, 0.2, integrator="rk4", dt=1e-3,
                                            project=True),
        "panda_pd_auto": lambda: sim(panda, pq0, np.zeros(panda.nv), 1.0, torque=_panda_pd(panda)),
        "panda_pd_rk4": lambda: sim(panda, pq0, np.zeros(panda.nv), 0.2, torque=_panda_pd(panda),
                                    integrator="rk4", dt=2e-3),
        "panda_target_rk45": lambda: sim(panda, pq0, np.zeros(panda.nv), 0.2, integrator="rk45",
                                         torque=Target("panda_hand", [0.4, 0.1, 0.5], kp=100.0, kd=20.0,
                                                       posture=pq0, posture_kp=5.0)),
        "two_r_table_zoh": lambda: sim(two_r, [0.3, 0.2], [0.0, 0.0], 0.5, integrator="rk45",
                                       torque=Table([0.0, 0.2, 0.4], [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.5]],
                                                    hold="zoh")),
        "two_r_constant_euler": lambda: sim(two_r, [0.3, 0.2], [0.0, 0.0], 0.2, integrator="euler", dt=1e-3,
                                            torque=[0.5, -0.2]),
        "two_r_computed_torque": lambda: sim(two_r, [0.0, 0.2], [0.3, 0.0], 0.5, integrator="dop853",
                                             torque=ComputedTorque(t, ref_q, ref_v, ref_a, 100.0, 20.0)),
        "two_r_callable": lambda: sim(two_r, [0.3, 0.2], [0.0, 0.0], 0.1, integrator="rk4", dt=1e-3,
                                      torque=lambda t, q, v: -2.0 * q - 0.5 * v),
    }


def numbers(traj):
    """name -> array of everything a case gives that must stay bit-identical."""
    out = {"t": traj.t, "q": traj.q, "v": traj.v, "tau": traj.tau}
    if traj.lam is not None:
        out["lam"] = traj.lam
    out["report"] = np.array([np.nan if traj.report.get(k) is None else float(traj.report[k])
                              for k in REPORT_KEYS])
    return out


def digest(value):
    """What is kept of an array: its shape, the SHA-256 of its float64 bytes, its last row (for the message and
    the round-off comparison; a short vector, the report's numbers, whole)."""
    a = np.ascontiguousarray(value, np.float64)
    if a.ndim == 1 and a.size <= 16:
        last = a
    else:
        last = a.reshape(a.shape[0], -1)[-1] if a.ndim and a.shape[0] else a.reshape(-1)
    return {"shape": list(a.shape), "sha256": hashlib.sha256(a.tobytes()).hexdigest(),
            "last": [float(x) for x in last]}


def _libm_values(x):
    """libm's pow, exp, log, sin, cos, sqrt and atan2 on x, called through ctypes: the functions the C++ core calls
    (numpy has its own vectorised versions of some, which need not agree with libm in the last bit)."""
    import ctypes
    import ctypes.util
    libm = ctypes.CDLL(ctypes.util.find_library("m"))
    d = ctypes.c_double
    for name, nargs in (("pow", 2), ("exp", 1), ("log", 1), ("sin", 1), ("cos", 1), ("sqrt", 1), ("atan2", 2)):
        getattr(libm, name).restype, getattr(libm, name).argtypes = d, [d] * nargs
    out = np.empty((x.shape[0], 8))
    for i, xi in enumerate(x.tolist()):
        out[i] = (libm.pow(xi, 0.25), libm.pow(xi, -0.2), libm.exp(-xi), libm.log(xi), libm.sin(xi), libm.cos(xi),
                  libm.sqrt(xi), libm.atan2(xi, 1.0 + xi))
    return out


def arithmetic_signature():
    """SHA-256 of libm's results on 10,000 fixed arguments (module docstring)."""
    x = np.geomspace(1e-6, 1e3, 10_000)
    return hashlib.sha256(_libm_values(x).tobytes()).hexdigest()


def record():
    data = {"_arithmetic": arithmetic_signature()}
    for name, run in cases().items():
        data[name] = {key: digest(value) for key, value in numbers(run()).items()}
        print(name, flush=True)
    os.makedirs(os.path.dirname(GOLDEN), exist_ok=True)
    with open(GOLDEN, "w") as f:
        json.dump(data, f, indent=1)


if __name__ == "__main__":
    record()
