"""A simulation you step from your own loop: :class:`Simulator`.

``simulate`` is one call over a whole duration.  Reinforcement learning, MPC and hardware in the loop hold the loop
themselves: read the state, compute an action, apply it for one control period, repeat.  A :class:`Simulator` is
made once from a model and its scene (the torque source, contact, closed loops, the integrator and its tolerances)
and holds one environment, or N of one model, in the C++ core (``core/simulation/simulator.hpp``)::

    sim = dynamics.Simulator(model, q0, v0, dt=0.01, torque=dynamics.torques.PD(kp, kd, q_target))
    for k in range(100):
        sim.step(tau)          # tau held over [t, t + dt), added to the PD's torques
        q, v = sim.q, sim.v    # read-only views of the core's state, no copies

Each period is one run of the integrator from the state the last one reached: an adaptive method keeps its
error control inside the period (and carries its step size, and ``auto`` its phase, to the next), a fixed-step
method takes ``ceil(dt / substep)`` steps.  The integration state is kept between periods, so stepping ``rk4`` with
``substep = dt`` gives the same bits as ``simulate`` sampled at the periods.  A period that fails (a NaN, a blow-up, a
step budget spent) leaves its environment at the period's start, marks it (``failed``, ``status``) and warns
(:class:`dynamics.SimulationWarning`); in a batch the others go on.  Stepping a failed single simulation is an
error until ``reset`` or ``set_state``.
"""

import math
import threading
import time
from warnings import warn

import numpy as np

from .. import _core
from ..checks import real_number, vector
from ..control.registry import _REGISTRY, release_callable
from ..control.validation import make_source
from ..constraints import core_constraints
from ..errors import DeadlineExceeded, InputError, SimulationWarning
from ..parallel import num_threads, seconds_left
from . import native
from .report import WHY
from .simulate import INTEGRATORS, _blowup, _check_q, _passive, _project_initial, _settings
from .solvers import FIXED, ORDER, STATUS_NAMES

__all__ = ["Simulator"]

#: the layout of a state (:meth:`Simulator.state`): t, q (nq), v (nv), then the adaptive step carried to the next
#: period, auto's phase (0 non-stiff, 1 stiff), and the clock (the time the periods count from, their number)
STATE_EXTRA = 4

_REASONS = dict(WHY, max_steps="the step budget of one period (max_steps={max_steps}) ran out",
                aborted="the torque callable raised")


class Simulator:
    """N environments of one model stepped one control period at a time (module docs).

    q0 (nq,) or (N, nq) and v0 (nv,) or (N, nv) (a single v0 is shared): one environment, or N.  dt: the control
    period (s).  torque, contact, gravity, limits, limit_stiffness, limit_damping, friction_eps, baumgarte,
    project, rtol, atol: as :func:`dynamics.simulate`.  integrator: "auto" (default), "rk45", "dop853", "radau"
    (error control inside each period, ``rtol``/``atol``) or "euler", "implicit_euler", "rk4" (fixed steps of
    ``substep``, default ``dt``; ``implicit_euler`` for contact and stiff gains at MuJoCo's 2 ms).  max_steps: the step budget of one period (adaptive methods).  error_estimate: what :attr:`error`
    holds after each period: "local" (the adaptive methods' default: their embedded estimates, free), "rerun" (every
    period integrated again at half the substep, or at rtol and atol / 32, on a copy of the environment: about two
    to three times the cost, for any method), or "none" (the fixed-step methods' default).
    """

    def __init__(self, model, q0, v0, *, dt, torque=None, contact=None, integrator="auto", substep=None,
                 rtol=1e-6, atol=1e-8, max_steps=100_000, gravity=None, limits=None, limit_stiffness=1e4,
                 limit_damping=100.0, friction_eps=1e-3, baumgarte=None, project=False, error_estimate=None):
        dt = real_number("dt", dt, lo=0.0, lo_open=True)
        if integrator not in INTEGRATORS:
            raise InputError(f"integrator: expected one of {INTEGRATORS}, got {integrator!r}")
        fixed = integrator in FIXED
        substep = real_number("substep", dt if substep is None else substep, lo=0.0, lo_open=True)
        if fixed and dt / substep > max_steps:
            raise InputError(f"substep: {substep:g} needs {math.ceil(dt / substep)} steps per period of {dt:g} s, "
                             f"more than max_steps={max_steps}")
        if error_estimate not in (None, "local", "rerun", "none"):
            raise InputError(f"error_estimate: expected 'local', 'rerun' or 'none', got {error_estimate!r}")
        if error_estimate == "local" and fixed:
            raise InputError(f"error_estimate: 'local' needs an adaptive integrator ({integrator!r} has no embedded "
                             "estimate); 'rerun' gives one for any method")
        self.error_estimate = error_estimate or ("none" if fixed else "local")
        Q0, V0, self.batched = _initial_states(model, q0, v0)
        warnings = []
        s = _settings(model, Q0[0], V0[0], dt, integrator, rtol, atol, substep if fixed else None, None, gravity,
                      max_steps, "none", ("q", "v"), warnings, baumgarte, project, contact)
        self.model, self.dt, self.integrator, self.substep = model, dt, integrator, substep if fixed else None
        self._settings = s
        self._q0, self._v0 = self._checked_rows(Q0, V0, warnings)
        ps = _passive(model, s, limits, limit_stiffness, limit_damping, friction_eps)
        src = make_source(model, torque)
        try:
            fn = _REGISTRY[src.slot][0] if src.slot >= 0 else None
            core_src = native.core_source(model, src)
        finally:
            if src.slot >= 0:
                release_callable(src.slot)
        self._arrays = _new_arrays(model, len(self._q0), contact is not None, s.constrained)
        a = self._arrays
        a["q"][:], a["v"][:] = self._q0, self._v0
        self._contacts = None
        self._blowup = _blowup(self._v0)
        from ..contact.resolve import core_contact
        rerun = self.error_estimate == "rerun"
        if s.contact is not None:  # one per environment, and one per shadow of the rerun
            self._contacts = [core_contact(s.contact, model) for _ in range(self.n * (2 if rerun else 1))]
        constrained = None
        if s.constrained:
            constrained = (core_constraints(model), float(s.baumgarte[0]), float(s.baumgarte[1]), bool(s.project))
        settings = {"method": integrator, "dt": dt, "substep": substep, "rtol": s.rtol, "atol": s.atol,
                    "max_steps": int(max_steps), "blowup": self._blowup, "rerun": rerun,
                    "order": ORDER.get(integrator, 0)}
        passive = native.core_passive(model, ps)
        check = native._torque_check(model.nv) if fn is not None else None

        def make(contacts, arrays):
            return _core.Simulator(model.core, passive, core_src, fn, check,
                                   None if contacts is None else [c.core for c in contacts], constrained, settings,
                                   arrays)
        def probe():  # one environment, stepped once (the steppers and the Jacobian's workspace are made lazily)
            one = _new_arrays(model, 1, contact is not None, s.constrained)
            one["q"][:], one["v"][:] = self._q0[:1], self._v0[:1]
            sim = make(None if s.contact is None else [core_contact(s.contact, model) for _ in range(1 + rerun)], one)
            if fn is None:  # (a torque callable is not called before the loop asks: made only, the rest guessed)
                sim.step(1, math.inf)
            return sim
        _refuse_unaffordable(self.n, probe, _workspace_guess(model, contact is not None, rerun))
        self._core = make(self._contacts, a)
        self._views = {k: _read_only(a[k]) for k in ("t", "q", "v", "error", "w")}
        self._wall = 0.0
        self._lock = threading.Lock()  # one step, reset or set_state at a time (the core's state is one)
        self._tau, self._status = a["tau"], a["status"]
        self._tau_shapes = ((model.nv,), (self.n, model.nv)) if self.batched else ((model.nv,),)
        for message in warnings:
            warn(message, SimulationWarning, stacklevel=2)

    # ---------------------------------------------------------------------------------------------------------
    # the loop
    def step(self, tau=None):
        """Advance every environment one period ``dt`` under ``tau`` held constant over it, added to the torque
        source's: None (zero), (nv,) (every environment) or (N, nv).  Threads calling it on one simulator take
        turns."""
        with self._lock:
            if tau is None:
                self._tau.fill(0.0)
            elif type(tau) is not np.ndarray or tau.dtype != np.float64 or tau.shape not in self._tau_shapes:
                self._held(tau)  # (checked and copied here; else the core copies it: a float64 array of its size)
                tau = None
            before = self._status.copy() if self.batched else None
            tic = time.perf_counter()
            try:
                failed, skipped, expired, bad = self._core.step(num_threads(), seconds_left(), tau)
                if bad == -2:  # not C-contiguous: copied here
                    self._held(tau)
                    failed, skipped, expired, bad = self._core.step(num_threads(), seconds_left(), None)
            finally:
                self._wall += time.perf_counter() - tic
            if bad >= 0 or expired or failed or (skipped and not self.batched):
                self._after_step(failed, skipped, expired, bad, before)

    def _after_step(self, failed, skipped, expired, bad, before):
        """What a step that did not simply succeed says: a non-finite torque, a single simulation stepped after its
        failure, the deadline, the environments that failed in it."""
        a = self._arrays
        if bad >= 0:
            self._refuse_torque(*divmod(bad, self.model.nv))
        if skipped and not self.batched:
            raise InputError(f"step: the simulation failed at t={a['t'][0]:.6g} s ({self.status}); call reset() "
                             "or set_state() before stepping again")
        if expired:
            done = int(np.count_nonzero(a["count"]))
            raise DeadlineExceeded("Simulator.step ran past its deadline; environments not stepped are left at their "
                                   "period's start (see .t)", done=done, total=self.n)
        if failed:
            self._warn_failed(np.flatnonzero(a["status"] != before) if self.batched else np.array([0]))

    def _held(self, tau):
        a, nv = self._arrays, self.model.nv
        x = np.asarray(tau, dtype=np.float64)
        if x.shape == (nv,) or (self.batched and x.shape == (self.n, nv)):
            np.copyto(a["tau"], x, casting="same_kind")
        else:
            want = f"({nv},)" + (f" or ({self.n}, {nv})" if self.batched else "")
            raise InputError(f"tau: expected shape {want}, got {np.shape(tau)}")

    def _refuse_torque(self, i, j):
        """A non-finite held torque (the core found it before stepping anything)."""
        where = f"environment {i}, " if self.batched else ""
        raise InputError(f"tau: {where}velocity coordinate {j} (joint {_joint_of(self.model, j)!r}) is "
                         f"{self._arrays['tau'][i, j]}; expected finite torques")

    def _warn_failed(self, which):
        """One warning per step: the environments that failed in it (the first five named)."""
        a = self._arrays
        said = [f"{'environment ' + str(i) + ': ' if self.batched else ''}the period from t={a['t'][i]:.6g} s "
                f"failed, {self._reason(i)}" for i in which[:5]]
        more = f" ({len(which) - 5} more environments failed in this step: see .failed)" if len(which) > 5 else ""
        warn("; ".join(said) + more + "; left at the period's start: reset() or set_state() to go on",
             SimulationWarning, stacklevel=3)

    def _reason(self, i):
        name = STATUS_NAMES[int(self._arrays["status"][i])] if self._arrays["status"][i] < 6 else "aborted"
        return _REASONS.get(name, name).format(blowup=self._blowup, max_steps=self._settings.max_steps)

    def reset(self, q=None, v=None, *, which=None, t=0.0):
        """Start environments again from (q, v) at time t: the initial states when q or v is None; ``which``:
        None (all), indices or a boolean mask of the environments to reset (then q, v have a row per one, or a
        single row for all of them)."""
        idx = self._which(which)
        Q = self._q0[idx] if q is None else self._rows("q", q, self.model.nq, len(idx))
        V = self._v0[idx] if v is None else self._rows("v", v, self.model.nv, len(idx))
        warnings = []
        Q, V = self._checked_rows(Q, V, warnings)
        t = np.full(len(idx), real_number("t", t))
        k = len(idx)
        self._load(idx, t, Q, V, np.zeros(k), np.zeros(k, np.int64), np.stack([t, np.zeros(k)], axis=1))
        for message in warnings:
            warn(message, SimulationWarning, stacklevel=2)

    def state(self):
        """A copy of the full state: (N, 1 + nq + nv + 4) rows, or one row for a single simulation, each
        [t, q, v, h, phase, t_origin, periods]: the adaptive step carried to the next period, auto's phase, and the
        time the periods are counted from with their number (period k ends at t_origin + k dt).  What
        :meth:`set_state` takes to branch or roll back (MPC): the same state and torques give the same bits every
        time; a fixed-step method gives the bits of the first continuation too, an adaptive one agrees with it
        within its tolerance (it starts its step controller and radau's Newton matrix afresh)."""
        a, nq, nv = self._arrays, self.model.nq, self.model.nv
        x = np.empty((self.n, 1 + nq + nv + STATE_EXTRA))
        x[:, 0], x[:, 1:1 + nq], x[:, 1 + nq:1 + nq + nv] = a["t"], a["q"], a["v"]
        x[:, 1 + nq + nv], x[:, 2 + nq + nv], x[:, 3 + nq + nv:] = a["h"], a["phase"], a["clock"]
        return x if self.batched else x[0]

    def set_state(self, x, *, which=None):
        """Go back to a state :meth:`state` returned (rows for the environments ``which``, as :meth:`reset`)."""
        nq, nv = self.model.nq, self.model.nv
        idx = self._which(which)
        X = self._rows("x", x, 1 + nq + nv + STATE_EXTRA, len(idx))
        if not np.isfinite(X).all():
            raise InputError("x: expected finite numbers (a row of Simulator.state())")
        phase = X[:, 2 + nq + nv]
        if not np.isin(phase, (0.0, 1.0)).all():
            raise InputError("x: the phase column must be 0 or 1 (a row of Simulator.state())")
        warnings = []
        Q, V = self._checked_rows(X[:, 1:1 + nq], X[:, 1 + nq:1 + nq + nv], warnings, project=False)
        if not (X[:, 4 + nq + nv] >= 0).all():
            raise InputError("x: the periods column must be >= 0 (a row of Simulator.state())")
        self._load(idx, X[:, 0], Q, V, np.maximum(X[:, 1 + nq + nv], 0.0), phase.astype(np.int64),
                   X[:, 3 + nq + nv:])

    def _load(self, idx, t, Q, V, h, phase, clock):
        a = self._arrays
        with self._lock:
            a["t"][idx], a["q"][idx], a["v"][idx], a["h"][idx], a["phase"][idx] = t, Q, V, h, phase
            a["clock"][idx] = clock
            a["error"][idx] = np.nan
            self._core.load(np.ascontiguousarray(idx, np.int64))

    # ---------------------------------------------------------------------------------------------------------
    # what the loop reads
    @property
    def n(self):
        """The number of environments."""
        return self._arrays["t"].shape[0]

    @property
    def t(self):
        """Time (s): a float, or (N,) per environment."""
        return self._views["t"] if self.batched else float(self._arrays["t"][0])

    @property
    def q(self):
        """Configuration (nq,) or (N, nq): a read-only view of the core's state (copy it to keep it)."""
        return self._views["q"] if self.batched else self._views["q"][0]

    @property
    def v(self):
        """Velocity (nv,) or (N, nv): a read-only view of the core's state."""
        return self._views["v"] if self.batched else self._views["v"][0]

    @property
    def error(self):
        """The last period's error estimate, max-norm over the components of (q, v) at its end: with
        ``error_estimate="local"`` the embedded local errors of its accepted steps summed, with "rerun" the
        difference from the same period integrated again at half the substep (times 2^p / (2^p - 1)) or at rtol /
        32; NaN with "none" and before the first step; inf when the rerun failed."""
        return self._views["error"] if self.batched else float(self._arrays["error"][0])

    @property
    def energy(self):
        """(kinetic, potential) energy at the present state (J), (2,) or (N, 2): computed when read."""
        from ..energy import kinetic_energy, potential_energy
        a = self._arrays
        e = np.stack([np.atleast_1d(kinetic_energy(self.model, a["q"], a["v"])),
                      np.atleast_1d(potential_energy(self.model, a["q"], gravity=self._settings.gravity))], axis=1)
        return e if self.batched else e[0]

    @property
    def work(self):
        """The work done over the last period by the torque source (the held torque included), the passive
        torques and, with contact, the contact forces (J): (2 or 3,) or (N, 2 or 3)."""
        w = self._views["w"]
        return w if self.batched else w[0]

    @property
    def failed(self):
        """Whether a period failed (and the environment waits for reset or set_state): bool or (N,) bool."""
        f = self._arrays["status"] != 0
        return f if self.batched else bool(f[0])

    @property
    def status(self):
        """"ok", or why the environment's last period failed: a str, or a list of N."""
        out = ["ok" if not s else f"failed: {self._reason(i)}" for i, s in enumerate(self._arrays["status"])]
        return out if self.batched else out[0]

    @property
    def stats(self):
        """What the steps cost, summed over the environments since the simulator was made: steps, rejected
        steps, right-hand sides, Jacobians, and the wall time spent in step() (s)."""
        c = self._arrays["counters"].sum(axis=0)
        return {"steps": int(c[0]), "rejected_steps": int(c[1]), "rhs_evals": int(c[2]),
                "jacobian_evals": int(c[3]), "wall_time_s": self._wall}

    def contact_forces(self, env=None, *, details=False):
        """The contact wrenches at the present state of environment ``env`` (default: the only one), as
        :func:`dynamics.contact_forces`: f_ext (nbodies, 6), or (f_ext, ContactDetails) with ``details``."""
        if self._settings.contact is None:
            raise InputError("contact_forces: this simulator has no contact (Simulator(..., contact=...))")
        from ..contact.evaluation import contact_forces
        i = self._env(env)
        a = self._arrays
        return contact_forces(self.model, self._settings.contact, a["q"][i].copy(), a["v"][i].copy(), details=details)

    def __repr__(self):
        what = f"{self.n} environments" if self.batched else f"t={self.t:.6g}"
        return f"<dynamics.Simulator {self.model.name!r} {self.integrator} dt={self.dt:g} {what}>"

    # ---------------------------------------------------------------------------------------------------------
    # checks
    def _env(self, env):
        if env is None:
            if self.batched:
                raise InputError(f"env: which environment (0 to {self.n - 1})? this simulator holds {self.n}")
            return 0
        if isinstance(env, bool) or not isinstance(env, (int, np.integer)) or not 0 <= env < self.n:
            raise InputError(f"env: expected an int in [0, {self.n}), got {env!r}")
        return int(env)

    def _which(self, which):
        if which is None:
            return np.arange(self.n)
        w = np.asarray(which)
        if w.dtype == bool:
            if w.shape != (self.n,):
                raise InputError(f"which: a boolean mask of shape ({self.n},), got {w.shape}")
            return np.flatnonzero(w)
        if w.ndim > 1 or not np.issubdtype(w.dtype, np.integer) or (w.size and not (0 <= w.min() and w.max() < self.n)):
            raise InputError(f"which: expected environment indices in [0, {self.n}) or a boolean mask, got {which!r}")
        return np.unique(w.reshape(-1))

    def _rows(self, name, x, n, k):
        x = np.asarray(x, dtype=np.float64)
        if x.shape == (n,):
            return np.broadcast_to(x, (k, n)).copy()
        if x.shape == (k, n):
            return x.copy()
        raise InputError(f"{name}: expected shape ({n},) or ({k}, {n}), got {x.shape}")

    def _checked_rows(self, Q, V, warnings, project=True):
        """Every row's unit blocks normalised (with a warning) and, for a constrained model with ``project``,
        projected onto the constraints, as simulate does with q0."""
        model, s = self.model, self._settings
        Q = np.array([_check_q(model, q, warnings) for q in Q]).reshape(-1, model.nq)
        V = np.array([vector("v0", v, model.nv) for v in V]).reshape(-1, model.nv)
        if s.constrained and s.project and project:
            for i in range(len(Q)):
                Q[i], V[i] = _project_initial(model, Q[i], V[i], warnings)
        return np.ascontiguousarray(Q), np.ascontiguousarray(V)


def _initial_states(model, q0, v0):
    """(Q0 (N, nq), V0 (N, nv), batched) from a single state or a batch."""
    nq, nv = model.nq, model.nv
    Q = np.asarray(q0, dtype=np.float64)
    V = np.asarray(v0, dtype=np.float64)
    if Q.ndim == 2 and Q.shape[1] == nq and Q.shape[0] >= 1:
        N = Q.shape[0]
        if V.shape == (nv,):
            V = np.broadcast_to(V, (N, nv))
        elif V.shape != (N, nv):
            raise InputError(f"v0: expected shape ({nv},) or ({N}, {nv}) for {N} environments, got {V.shape}")
        return Q, V, True
    if Q.shape != (nq,):
        raise InputError(f"q0: expected shape ({nq},) or (N, {nq}), got {Q.shape}")
    if V.shape != (nv,):
        raise InputError(f"v0: expected shape ({nv},), got {V.shape}")
    return Q[None], V[None], False


def _workspace_guess(model, contact, rerun):
    """A generous guess of one environment's bytes where the allocator cannot be asked (not glibc's, or under a
    sanitizer): the workspaces per body and the integrator's matrices of the state's size."""
    nb, n = model.tree.parents.shape[0], 2 * model.nv + 3
    each = 8 * (40 * 36 * nb + 12 * n * n) + (64 * 1024 if contact else 0)
    return each * (2 if rerun else 1)


def _refuse_unaffordable(n, make_one, guess):
    """Refuse n environments whose workspaces would not fit in the memory available (rather than let the kernel kill
    the process): one environment is made, stepped once, and its allocations counted (glibc's mallinfo2), or
    ``guess`` bytes each where they cannot be counted."""
    if n < 64:
        return
    used = _malloc_bytes()
    one = make_one()
    each = _malloc_bytes() - used if used is not None else 0
    del one
    if each < 4096:  # the allocator does not count (another allocator, a sanitizer's): the guess
        each = guess
    each = max(each, guess // 4)  # (a probe not stepped has made no stepper yet)
    available = _available_memory()
    if available is not None and n * each > 0.8 * available:
        raise InputError(f"q0: {n} environments would take about {n * each / 2**30:.3g} GiB "
                         f"({each / 2**10:.0f} KiB each: the integrator's and contact's workspaces), more than the "
                         f"{available / 2**30:.3g} GiB this machine has available; step fewer at once")


def _malloc_bytes():
    try:
        import ctypes

        class MallInfo2(ctypes.Structure):
            _fields_ = [(name, ctypes.c_size_t) for name in ("arena", "ordblks", "smblks", "hblks", "hblkhd",
                                                              "usmblks", "fsmblks", "uordblks", "fordblks",
                                                              "keepcost")]
        libc = ctypes.CDLL(None)
        libc.mallinfo2.restype = MallInfo2
        info = libc.mallinfo2()
        return int(info.uordblks) + int(info.hblkhd)
    except (OSError, AttributeError):
        return None


def _available_memory():
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def _new_arrays(model, N, contact, constrained):
    """The arrays the core's simulator reads and writes (bindings/simulator.cpp)."""
    nq, nv = model.nq, model.nv
    return {"t": np.zeros(N), "q": np.zeros((N, nq)), "v": np.zeros((N, nv)), "h": np.zeros(N),
            "phase": np.zeros(N, np.int64), "status": np.zeros(N, np.int64), "error": np.full(N, np.nan),
            "w": np.zeros((N, 3 if contact else 2)), "count": np.zeros(N, np.int64),
            "counters": np.zeros((N, 4), np.int64), "clock": np.zeros((N, 2)), "drift": np.zeros((N if constrained else 0, 3)),
            "tau": np.zeros((N, nv))}


def _joint_of(model, j):
    """The name of the joint velocity coordinate j belongs to."""
    v_idx = np.asarray(model.tree.v_idx)
    return model.joint_names[int(np.searchsorted(v_idx, j, side="right")) - 1]


def _read_only(a):
    view = a.view()
    view.flags.writeable = False
    return view
