"""Time steppers for y' = f(t, y): symplectic Euler, RK4, Dormand-Prince 5(4), Radau IIA(5), and ``auto``.

Every solver here is a ``numba.njit`` function of one opaque problem ``p``, so the same compiled code
integrates a robot (:mod:`dynamics.simulate`) or a plain ODE (the tests).  ``p`` is an instance of a
``typing.NamedTuple`` subclass that carries four njit functions as class attributes; the solvers reach them
through the overloaded stubs below, resolved at compile time from ``type(p)`` (static calls, so the callers
stay cacheable, which passing functions as arguments would not):

* ``rhs(p, t, z, dz)``: write dz = f(t, z);
* ``rebase(p, z, dz, mag)``: called after every accepted step.  A problem that integrates in a moving chart
  (the robot's configuration, see :mod:`dynamics.integrate`) re-centres it here, i.e. folds the chart
  coordinates of z into its base point and zeroes them, rewrites the chart part of ``dz = f(t, z)``
  for the new chart, and stores in ``mag`` the magnitude of every state component (|q| for a chart
  coordinate) for the relative tolerance.  Plain ODEs do nothing;
* ``euler_config(p, z, h)``: symplectic Euler's position update from the (already updated) velocity part;
* ``emit(p, j, t, z)``: record output sample j at time t (z is in the chart of the current step).

State layout: z = [configuration part (nc), velocity part (nvel), quadratures].  Only the first ``ne``
components enter error norms and Newton convergence tests; components from ``ne`` on are quadratures
(the robot's work integral): f must not depend on them.

Methods (Hairer, Norsett & Wanner, "Solving ODEs I", 2nd ed. 1993 = [HNW]; Hairer & Wanner, "Solving ODEs
II", 2nd ed. 1996 = [HW]):

* ``euler``: semi-implicit (symplectic) Euler, v+ = v + h a(q, v), q+ = q (+) h v+ (first order, fixed h).
* ``rk4``: the classical Runge-Kutta method (fourth order, fixed h); samples between steps come from the
  cubic Hermite interpolant of (z, f) at both ends.
* ``rk45``: Dormand & Prince 5(4) with local extrapolation, FSAL, the PI step-size controller of DOPRI5
  ([HNW] sec. IV.2, beta = 0.04), Shampine's quartic dense output, and DOPRI5's stiffness test
  ([HW] sec. IV.2: h*|lambda| estimated from the last two stages exceeds 3.25 on 15 accepted steps).
* ``dop853``: Hairer's explicit Runge-Kutta method of order 8 with the 5th/3rd-order combined error
  estimate and the 7th-order dense output (3 extra stages, only on steps that hold output samples) ([HNW]
  sec. II.10; the structure follows ``scipy.integrate.DOP853``).  The cheapest for smooth, non-stiff
  problems at tight tolerances; no stiffness test.
* ``radau``: Radau IIA of order 5 (3 stages, L-stable, stiffly accurate) with a simplified Newton iteration
  on a finite-difference Jacobian, the real/complex splitting of the stage system, the embedded
  third-order error estimate filtered through (1 - h gamma J)^-1 and Gustafsson's predictive controller
  ([HW] sec. IV.8; the structure follows ``scipy.integrate.Radau``).
* ``auto``: starts with ``rk45``; when the stiffness test fires it switches to ``radau``; while on
  ``radau`` it estimates the spectral radius rho of the Jacobian (power iteration) and switches back when
  h*rho < 2 (the explicit method would be stable at the same step) on 20 accepted steps in a row, the way
  LSODA alternates between Adams and BDF.  Every switch is logged with its time and reason.

Statuses returned: ``OK``, ``NONFINITE`` (a NaN/inf appeared and step reduction could not avoid it),
``BLOWUP`` (a velocity exceeded ``blowup``), ``MAX_STEPS`` (step budget spent), ``STEP_TOO_SMALL``.
"""

import numpy as np
from numba.extending import overload

from ._numba import GENERIC_OPTIONS, generic_kernel, kernel


# ---------------------------------------------------------------------------------------------------
# the problem interface: stubs resolved from type(p) at compile time
def problem_rhs(p, t, z, dz):
    """dz = f(t, z) (compiled code only)."""
    raise NotImplementedError


def problem_rebase(p, z, dz, mag):
    """Re-centre the chart after an accepted step (compiled code only)."""
    raise NotImplementedError


def problem_euler_config(p, z, h):
    """Symplectic Euler's configuration update (compiled code only)."""
    raise NotImplementedError


def problem_emit(p, j, t, z):
    """Record output sample j (compiled code only)."""
    raise NotImplementedError


def _method(p, name):
    fn = getattr(getattr(p, "instance_class", None), name, None)
    if fn is None:
        raise TypeError(f"{p} is not a problem type: its NamedTuple class needs the njit attribute {name!r}")
    return fn


@overload(problem_rhs, jit_options=GENERIC_OPTIONS)
def _ov_rhs(p, t, z, dz):
    fn = _method(p, "rhs")
    return lambda p, t, z, dz: fn(p, t, z, dz)


@overload(problem_rebase, jit_options=GENERIC_OPTIONS)
def _ov_rebase(p, z, dz, mag):
    fn = _method(p, "rebase")
    return lambda p, z, dz, mag: fn(p, z, dz, mag)


@overload(problem_euler_config, jit_options=GENERIC_OPTIONS)
def _ov_euler_config(p, z, h):
    fn = _method(p, "euler_config")
    return lambda p, z, h: fn(p, z, h)


@overload(problem_emit, jit_options=GENERIC_OPTIONS)
def _ov_emit(p, j, t, z):
    fn = _method(p, "emit")
    return lambda p, j, t, z: fn(p, j, t, z)

EULER, RK4, RK45, RADAU, AUTO, DOP853 = 0, 1, 2, 3, 4, 5
METHOD_NAMES = ("euler", "rk4", "rk45", "radau", "auto", "dop853")

OK, NONFINITE, BLOWUP, MAX_STEPS, STEP_TOO_SMALL = 0, 1, 2, 3, 4
STATUS_NAMES = ("ok", "nonfinite", "blowup", "max_steps", "step_too_small")

# switch reasons
SWITCH_STIFF, SWITCH_NONSTIFF = 0, 1

# integer options / statistics (index names)
I_NC, I_NVEL, I_NE, I_MAXSTEPS, I_NSTEPS = 0, 1, 2, 3, 4
S_STEPS, S_REJECTED, S_NFEV, S_NJEV, S_NLU, S_NSWITCH, S_STIFF_HITS, S_STATUS = 0, 1, 2, 3, 4, 5, 6, 7
# float options / statistics
F_RTOL, F_ATOL, F_H0, F_HMAX, F_BLOWUP = 0, 1, 2, 3, 4
FS_T, FS_LOCAL_ERR, FS_H, FS_STIFF_T, FS_HRHO = 0, 1, 2, 3, 4

MAX_SWITCHES = 64

# ---------------------------------------------------------------------------------------------------
# Dormand-Prince 5(4) tableau, error weights and dense-output polynomial ([HNW] table II.5.2; Shampine 1986)
DP_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0])
DP_A = np.array([
    [0, 0, 0, 0, 0],
    [1 / 5, 0, 0, 0, 0],
    [3 / 40, 9 / 40, 0, 0, 0],
    [44 / 45, -56 / 15, 32 / 9, 0, 0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656]])
DP_B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
DP_A7 = np.zeros((7, 6))  # A with the weights as 7th row: the last stage is the new point (FSAL)
DP_A7[:6, :5] = DP_A
DP_A7[6, :] = DP_B
DP_C7 = np.append(DP_C, 1.0)
DP_E = np.array([-71 / 57600, 0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])
DP_P = np.array([
    [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0, 0, 0, 0],
    [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
    [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
    [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423]])

# DOP853 (Hairer's DOP853, coefficients as in scipy.integrate's dop853_coefficients): 12 stages + FSAL,
# rows 13-15 of A8 are the extra stages of the 7th-order dense output
A8 = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.05260015195876773, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0197250569845379, 0.0591751709536137, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.02958758547680685, 0.0, 0.08876275643042054, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.2413651341592667, 0.0, -0.8845494793282861, 0.924834003261792, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.037037037037037035, 0.0, 0.0, 0.17082860872947386, 0.12546768756682242, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.037109375, 0.0, 0.0, 0.17025221101954405, 0.06021653898045596, -0.017578125, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.03709200011850479, 0.0, 0.0, 0.17038392571223998, 0.10726203044637328, -0.015319437748624402, 0.008273789163814023, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.6241109587160757, 0.0, 0.0, -3.3608926294469414, -0.868219346841726, 27.59209969944671, 20.154067550477894, -43.48988418106996, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.47766253643826434, 0.0, 0.0, -2.4881146199716677, -0.590290826836843, 21.230051448181193, 15.279233632882423, -33.28821096898486, -0.020331201708508627, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [-0.9371424300859873, 0.0, 0.0, 5.186372428844064, 1.0914373489967295, -8.149787010746927, -18.52006565999696, 22.739487099350505, 2.4936055526796523, -3.0467644718982196, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [2.273310147516538, 0.0, 0.0, -10.53449546673725, -2.0008720582248625, -17.9589318631188, 27.94888452941996, -2.8589982771350235, -8.87285693353063, 12.360567175794303, 0.6433927460157636, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.054293734116568765, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003, -5.801203960010585, 0.3111643669578199, -0.1521609496625161, 0.20136540080403034, 0.04471061572777259, 0.0, 0.0, 0.0, 0.0],
    [0.056167502283047954, 0.0, 0.0, 0.0, 0.0, 0.0, 0.25350021021662483, -0.2462390374708025, -0.12419142326381637, 0.15329179827876568, 0.00820105229563469, 0.007567897660545699, -0.008298, 0.0, 0.0, 0.0],
    [0.03183464816350214, 0.0, 0.0, 0.0, 0.0, 0.028300909672366776, 0.053541988307438566, -0.05492374857139099, 0.0, 0.0, -0.00010834732869724932, 0.0003825710908356584, -0.00034046500868740456, 0.1413124436746325, 0.0, 0.0],
    [-0.42889630158379194, 0.0, 0.0, 0.0, 0.0, -4.697621415361164, 7.683421196062599, 4.06898981839711, 0.3567271874552811, 0.0, 0.0, 0.0, -0.0013990241651590145, 2.9475147891527724, -9.15095847217987, 0.0],])
C8 = np.array([0.0, 0.05260015195876773, 0.0789002279381516, 0.1183503419072274, 0.2816496580927726, 0.3333333333333333, 0.25, 0.3076923076923077, 0.6512820512820513, 0.6, 0.8571428571428571, 1.0, 1.0, 0.1, 0.2, 0.7777777777777778])
E3_8 = np.array([-0.18980075407240762, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003, -5.801203960010585, -0.4226823213237919, -0.1521609496625161, 0.20136540080403034, 0.02265179219836082, 0.0])
E5_8 = np.array([0.01312004499419488, 0.0, 0.0, 0.0, 0.0, -1.2251564463762044, -0.4957589496572502, 1.6643771824549864, -0.35032884874997366, 0.3341791187130175, 0.08192320648511571, -0.022355307863886294, 0.0])
D8 = np.array([
    [-8.428938276109013, 0.0, 0.0, 0.0, 0.0, 0.5667149535193777, -3.0689499459498917, 2.38466765651207, 2.117034582445028, -0.871391583777973, 2.2404374302607883, 0.6315787787694688, -0.08899033645133331, 18.148505520854727, -9.194632392478356, -4.436036387594894],
    [10.427508642579134, 0.0, 0.0, 0.0, 0.0, 242.28349177525817, 165.20045171727028, -374.5467547226902, -22.113666853125306, 7.733432668472264, -30.674084731089398, -9.332130526430229, 15.697238121770845, -31.139403219565178, -9.35292435884448, 35.81684148639408],
    [19.985053242002433, 0.0, 0.0, 0.0, 0.0, -387.0373087493518, -189.17813819516758, 527.8081592054236, -11.57390253995963, 6.8812326946963, -1.0006050966910838, 0.7777137798053443, -2.778205752353508, -60.19669523126412, 84.32040550667716, 11.99229113618279],
    [-25.69393346270375, 0.0, 0.0, 0.0, 0.0, -154.18974869023643, -231.5293791760455, 357.6391179106141, 93.40532418362432, -37.45832313645163, 104.0996495089623, 29.8402934266605, -43.53345659001114, 96.32455395918828, -39.17726167561544, -149.72683625798564],])

# Radau IIA(5) ([HW] sec. IV.8): nodes, error weights, A = T diag(mu) T^-1 split, dense output
_S6 = 6 ** 0.5
RA_C = np.array([(4 - _S6) / 10, (4 + _S6) / 10, 1.0])
RA_E = np.array([-13 - 7 * _S6, -13 + 7 * _S6, -1.0]) / 3
RA_MU_REAL = 3 + 3 ** (2 / 3) - 3 ** (1 / 3)
RA_MU_CRE = 3 + 0.5 * (3 ** (1 / 3) - 3 ** (2 / 3))
RA_MU_CIM = -0.5 * (3 ** (5 / 6) + 3 ** (7 / 6))
RA_T = np.array([
    [0.09443876248897524, -0.14125529502095421, 0.03002919410514742],
    [0.25021312296533332, 0.20412935229379994, -0.38294211275726192],
    [1, 1, 0]])
RA_TI = np.array([
    [4.17871859155190428, 0.32768282076106237, 0.52337644549944951],
    [-4.17871859155190428, -0.32768282076106237, 0.47662355450055044],
    [0.50287263494578682, -2.57192694985560522, 0.59603920482822492]])
RA_P = np.array([
    [13 / 3 + 7 * _S6 / 3, -23 / 3 - 22 * _S6 / 3, 10 / 3 + 5 * _S6],
    [13 / 3 - 7 * _S6 / 3, -23 / 3 + 22 * _S6 / 3, 10 / 3 - 5 * _S6],
    [1 / 3, -8 / 3, 10 / 3]])
NEWTON_MAXITER = 6


# ---------------------------------------------------------------------------------------------------
# small helpers
@kernel
def lu_factor(A, piv):
    """In-place LU with partial pivoting (real or complex A): P A = L U, L unit lower triangular."""
    n = A.shape[0]
    for k in range(n):
        m = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                m = i
        piv[k] = m
        if m != k:
            for j in range(n):
                tmp = A[k, j]
                A[k, j] = A[m, j]
                A[m, j] = tmp
        d = A[k, k]
        if d == 0:
            continue  # singular: the solve returns inf/nan and the step is rejected
        for i in range(k + 1, n):
            A[i, k] /= d
            lik = A[i, k]
            if lik != 0:
                for j in range(k + 1, n):
                    A[i, j] -= lik * A[k, j]


@kernel
def lu_solve(LU, piv, b):
    """Solve (P^T L U) x = b in place, given lu_factor's output."""
    n = LU.shape[0]
    for k in range(n):
        m = piv[k]
        if m != k:
            tmp = b[k]
            b[k] = b[m]
            b[m] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= LU[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= LU[i, j] * b[j]
        b[i] = s / LU[i, i]


@kernel
def scaled_rms(e, z0, z1, mag, ne, rtol, atol):
    """RMS of e_i / (atol + rtol max(|z0_i| + mag_i, |z1_i| + mag_i)) over the first ne components."""
    s = 0.0
    for i in range(ne):
        sc = atol + rtol * max(abs(z0[i]) + mag[i], abs(z1[i]) + mag[i])
        x = e[i] / sc
        s += x * x
    return np.sqrt(s / max(ne, 1))


@kernel
def _max_abs(x, ne):
    m = 0.0
    for i in range(ne):
        a = abs(x[i])
        if not a <= m:  # also propagates NaN
            m = a
    return m


@kernel
def _state_status(z, nc, nvel, blowup):
    """OK, NONFINITE or BLOWUP for a state (velocities above ``blowup`` count as a blow-up)."""
    for i in range(z.shape[0]):
        if not np.isfinite(z[i]):
            return NONFINITE
    for i in range(nc, nc + nvel):
        if abs(z[i]) > blowup:
            return BLOWUP
    return OK


@generic_kernel
def initial_step(p, t, z, f0, order, rtol, atol, mag, ne, t_end, istats):
    """Hairer's starting step ([HNW] sec. II.4), as scipy's ``select_initial_step``."""
    n = z.shape[0]
    span = t_end - t
    if span <= 0:
        return 0.0
    d0 = 0.0
    d1 = 0.0
    for i in range(ne):
        sc = atol + rtol * (abs(z[i]) + mag[i])
        d0 += (z[i] / sc) ** 2
        d1 += (f0[i] / sc) ** 2
    d0 = np.sqrt(d0 / max(ne, 1))
    d1 = np.sqrt(d1 / max(ne, 1))
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, span)
    z1 = np.empty(n)
    f1 = np.empty(n)
    for i in range(n):
        z1[i] = z[i] + h0 * f0[i]
    problem_rhs(p, t + h0, z1, f1)
    istats[S_NFEV] += 1
    d2 = 0.0
    for i in range(ne):
        sc = atol + rtol * (abs(z[i]) + mag[i])
        d2 += ((f1[i] - f0[i]) / sc) ** 2
    d2 = np.sqrt(d2 / max(ne, 1)) / h0
    if not np.isfinite(d2):
        return h0 * 1e-3
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    return min(100 * h0, h1, span)


@generic_kernel
def fd_jacobian(p, t, z, f0, mag, ne, J, istats):
    """Forward-difference Jacobian J = df/dz; columns of quadrature components (>= ne) are zero."""
    n = z.shape[0]
    zt = z.copy()
    ft = np.empty(n)
    for c in range(n):
        if c >= ne:
            for r in range(n):
                J[r, c] = 0.0
            continue
        d = 1.4901161193847656e-08 * max(1.0, abs(z[c]) + mag[c])
        zt[c] = z[c] + d
        d = zt[c] - z[c]  # the step actually representable
        problem_rhs(p, t, zt, ft)
        zt[c] = z[c]
        for r in range(n):
            J[r, c] = (ft[r] - f0[r]) / d
    istats[S_NFEV] += ne
    istats[S_NJEV] += 1


@kernel
def spectral_radius(J, ne):
    """Estimate of max |lambda(J)| by 30 power iterations (geometric mean of the last 15 growth ratios;
    this also gives the modulus for a dominant complex pair)."""
    n = ne
    x = np.empty(n)
    for i in range(n):
        x[i] = 1.0 + 0.1 * ((i * 7919) % 13)  # fixed, generic start vector
    nrm = np.sqrt(np.sum(x * x))
    if nrm == 0:
        return 0.0
    x /= nrm
    y = np.empty(n)
    logsum = 0.0
    cnt = 0
    for it in range(30):
        for r in range(n):
            s = 0.0
            for c in range(n):
                s += J[r, c] * x[c]
            y[r] = s
        nrm = np.sqrt(np.sum(y * y))
        if nrm == 0.0 or not np.isfinite(nrm):
            return 0.0 if nrm == 0.0 else np.inf
        if it >= 15:
            logsum += np.log(nrm)
            cnt += 1
        x[:] = y / nrm
    return np.exp(logsum / cnt)


# ---------------------------------------------------------------------------------------------------
# fixed-step solvers
@generic_kernel
def solve_fixed(p, method, z, t0, t_end, dt, out_t, iopt, fopt, istats, fstats):
    """Fixed steps of size dt from t0 to t_end (the last one shortened to land on t_end exactly).

    The slope at the end of a step serves the Hermite interpolant of that step and, re-expressed in the new
    chart by ``rebase``, the first stage of the next step (so RK4 costs 4 evaluations per step).  Every
    problem function has a single call site here, so the right-hand side is compiled (and inlined) once.
    """
    n = z.shape[0]
    nc = iopt[I_NC]
    nvel = iopt[I_NVEL]
    nsteps = iopt[I_NSTEPS]
    blowup = fopt[F_BLOWUP]
    mag = np.zeros(n)
    K = np.empty((5, n))  # K[0] slope at the start, K[1:4] RK4 stages 2-4, K[4] slope at the end
    zs = np.empty(n)
    zold = np.empty(n)
    zi = np.empty(n)
    c = (0.0, 0.5, 0.5, 1.0)
    nout = out_t.shape[0]
    j = 0
    status = OK
    t = t0
    tb = t0
    h = 0.0
    i = -1  # index of the step just taken; -1 before the first
    stage = 4  # 1-3: RK4 stages, 4: the slope at the end of step i (at t0 for i = -1)
    while True:
        if stage == 4:
            zs[:] = z
            ts = tb
        else:
            for r in range(n):
                zs[r] = z[r] + c[stage] * h * K[stage - 1, r]
            ts = t + c[stage] * h
        problem_rhs(p, ts, zs, K[stage])
        istats[S_NFEV] += 1
        if stage < 3:
            stage += 1
            continue
        if stage == 3:
            for r in range(n):
                z[r] += h / 6.0 * (K[0, r] + 2.0 * K[1, r] + 2.0 * K[2, r] + K[3, r])
            istats[S_STEPS] += 1
            status = _state_status(z, nc, nvel, blowup)
            if status != OK:
                t = tb
                break
            stage = 4
            continue
        # stage 4: the end slope of step i is known
        if _state_status(K[4], 0, 0, blowup) != OK:
            status = NONFINITE
            t = tb
            break
        while j < nout and out_t[j] <= tb:  # samples in (t, tb]
            if out_t[j] >= tb or i < 0:
                zi[:] = z
                ts = tb
            else:
                ts = out_t[j]
                x = (ts - t) / h
                if method == EULER:
                    for r in range(n):
                        zi[r] = zold[r] + x * (z[r] - zold[r])
                else:  # cubic Hermite through (z, slope) at both ends
                    h00 = (1 + 2 * x) * (1 - x) ** 2
                    h10 = x * (1 - x) ** 2
                    h01 = x * x * (3 - 2 * x)
                    h11 = x * x * (x - 1)
                    for r in range(n):
                        zi[r] = h00 * zold[r] + h10 * h * K[0, r] + h01 * z[r] + h11 * h * K[4, r]
            problem_emit(p, j, ts, zi)
            j += 1
        problem_rebase(p, z, K[4], mag)
        K[0, :] = K[4, :]
        t = tb
        i += 1
        if i >= nsteps:
            break
        # start step i: from t to tb
        tb = t0 + (i + 1) * dt
        if i == nsteps - 1 or tb > t_end:
            tb = t_end
        h = tb - t
        zold[:] = z
        if method == EULER:  # v+ = v + h a(q, v), then q+ = q (+) h v+; quadratures by explicit Euler
            for r in range(nc, n):
                z[r] += h * K[0, r]
            problem_euler_config(p, z, h)
            istats[S_STEPS] += 1
            status = _state_status(z, nc, nvel, blowup)
            if status != OK:
                t = tb
                break
            stage = 4
        else:
            stage = 1
    istats[S_STATUS] = status
    fstats[FS_T] = t
    fstats[FS_LOCAL_ERR] = np.nan  # fixed-step methods have no embedded error estimate
    fstats[FS_H] = dt
    return status


# ---------------------------------------------------------------------------------------------------
# adaptive solvers: rk45, radau and the auto switch in one loop
@generic_kernel
def solve_adaptive(p, method, z, t0, t_end, out_t, iopt, fopt, istats, fstats, switch_log):
    """Integrate from t0 to t_end with error control; ``method`` is RK45, DOP853, RADAU or AUTO.

    As in :func:`solve_fixed`, each problem function has as few call sites as possible (one per kind of
    evaluation), so the right-hand side is compiled a handful of times, not once per use.
    """
    n = z.shape[0]
    nc = iopt[I_NC]
    nvel = iopt[I_NVEL]
    ne = iopt[I_NE]
    max_steps = iopt[I_MAXSTEPS]
    rtol = fopt[F_RTOL]
    atol = fopt[F_ATOL]
    hmax = fopt[F_HMAX]
    blowup = fopt[F_BLOWUP]
    eps = 2.220446049250313e-16

    mag = np.zeros(n)
    K = np.empty((16, n))  # explicit stages (DP: 7, DOP853: 13 + 3 for dense output); K[0] = f(t, z)
    F8 = np.empty((7, n))  # DOP853 dense output
    znew = np.empty(n)
    zs = np.empty(n)
    y6 = np.empty(n)
    errv = np.empty(n)
    zi = np.empty(n)
    bx = np.empty(7)
    # Radau workspace
    J = np.zeros((n, n))
    LUr = np.empty((n, n))
    LUc = np.empty((n, n), dtype=np.complex128)
    pivr = np.empty(n, dtype=np.int64)
    pivc = np.empty(n, dtype=np.int64)
    Z = np.zeros((3, n))
    W = np.zeros((3, n))
    F = np.empty((3, n))
    dWr = np.empty(n)
    dWc = np.empty(n, dtype=np.complex128)
    Qd = np.zeros((n, 3))  # Radau dense output of the last accepted step
    fr = np.empty(n)
    fc = np.empty(n, dtype=np.complex128)
    mr = 0.0
    mc = 0j

    mode = RADAU if method == RADAU else (DOP853 if method == DOP853 else RK45)
    t = t0
    problem_rebase(p, z, K[0], mag)  # magnitudes of the initial state (z's chart part is zero)
    problem_rhs(p, t, z, K[0])
    istats[S_NFEV] += 1
    j = 0
    nout = out_t.shape[0]
    status = _state_status(K[0], 0, 0, blowup)
    h = fopt[F_H0]
    if h <= 0:
        h = initial_step(p, t, z, K[0], 5 if mode == RK45 else (8 if mode == DOP853 else 3), rtol, atol, mag, ne,
                         t_end, istats)
    h = min(h, hmax)
    errold = 1e-4  # PI controller memory (DOPRI5's facold)
    iasti = 0  # DOPRI5 stiffness test counters
    nonsti = 0
    need_jac = True  # Radau state
    current_jac = False
    have_lu = False
    have_sol = False
    h_sol = 1.0
    h_abs_old = -1.0
    err_norm_old = -1.0
    rho = -1.0
    nonstiff_count = 0
    newton_tol = max(10 * eps / rtol, min(0.03, rtol ** 0.5))
    local_err = 0.0
    total = 0
    rejected_last = False
    h_acc = 0.0  # size of the last accepted step
    acc_mode = mode
    fresh = True  # a step was just accepted (or we are at t0): emit samples, re-centre the chart
    dense_ready = False  # DOP853's extra stages for this step's dense output are computed

    while status == OK:
        # ---- samples in (t - h_acc, t] from the accepted step's dense output (t0 itself first)
        while fresh and j < nout and out_t[j] <= t:
            if out_t[j] >= t or h_acc == 0.0:
                zi[:] = z
                ts = t
            else:
                ts = out_t[j]
                x = (ts - (t - h_acc)) / h_acc
                if acc_mode == DOP853:
                    if not dense_ready:  # the 3 extra stages of the 7th-order interpolant
                        for st in range(13, 16):
                            for r in range(n):
                                acc = 0.0
                                for q in range(st):
                                    acc += A8[st, q] * K[q, r]
                                zi[r] = zs[r] + h_acc * acc
                            problem_rhs(p, t - h_acc + C8[st] * h_acc, zi, K[st])
                        istats[S_NFEV] += 3
                        for r in range(n):
                            dy = z[r] - zs[r]
                            F8[0, r] = dy
                            F8[1, r] = h_acc * K[0, r] - dy
                            F8[2, r] = 2 * dy - h_acc * (K[12, r] + K[0, r])
                            for m in range(4):
                                acc = 0.0
                                for q in range(16):
                                    acc += D8[m, q] * K[q, r]
                                F8[3 + m, r] = h_acc * acc
                        dense_ready = True
                    for r in range(n):
                        acc = 0.0
                        for m in range(6, -1, -1):
                            acc += F8[m, r]
                            if (6 - m) % 2 == 0:
                                acc *= x
                            else:
                                acc *= 1.0 - x
                        zi[r] = zs[r] + acc
                elif acc_mode == RK45:  # Shampine's quartic
                    for q in range(7):
                        bx[q] = x * (DP_P[q, 0] + x * (DP_P[q, 1] + x * (DP_P[q, 2] + x * DP_P[q, 3])))
                    for r in range(n):
                        acc = 0.0
                        for q in range(7):
                            acc += bx[q] * K[q, r]
                        zi[r] = zs[r] + h_acc * acc
                else:  # Radau's collocation polynomial
                    for r in range(n):
                        zi[r] = zs[r] + x * (Qd[r, 0] + x * (Qd[r, 1] + x * Qd[r, 2]))
            problem_emit(p, j, ts, zi)
            j += 1
        if fresh and h_acc > 0.0:
            # re-centre the chart; K[0] = f(t, z) in the new chart
            if acc_mode == RK45:
                K[0, :] = K[6, :]
            elif acc_mode == DOP853:
                K[0, :] = K[12, :]
            problem_rebase(p, z, K[0], mag)
        fresh = False
        if t >= t_end:
            break
        if total >= max_steps:
            status = MAX_STEPS
            break
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        if h < min_step:
            status = STEP_TOO_SMALL
            break
        h = min(h, hmax)
        tn = t + h
        if tn >= t_end or t_end - tn < min_step:
            tn = t_end
        h = tn - t
        total += 1
        accepted = False

        if mode == DOP853:
            # ---- one DOP853 attempt: stages 2-12 and the new point (stage 13, FSAL)
            for st in range(1, 13):
                for r in range(n):
                    acc = 0.0
                    for q in range(st):
                        acc += A8[st, q] * K[q, r]
                    zs[r] = z[r] + h * acc
                problem_rhs(p, t + C8[st] * h, zs, K[st])
            istats[S_NFEV] += 12
            znew[:] = zs
            e5 = 0.0
            e3 = 0.0
            for r in range(n):
                a5 = 0.0
                a3 = 0.0
                for q in range(13):
                    a5 += E5_8[q] * K[q, r]
                    a3 += E3_8[q] * K[q, r]
                errv[r] = h * a5  # local error estimate (for the "local" report)
                if r < ne:
                    sc = atol + rtol * max(abs(z[r]) + mag[r], abs(znew[r]) + mag[r])
                    e5 += (a5 / sc) ** 2
                    e3 += (a3 / sc) ** 2
            if e5 == 0.0 and e3 == 0.0:
                err = 0.0
            else:
                err = abs(h) * e5 / np.sqrt((e5 + 0.01 * e3) * max(ne, 1))
            if not np.isfinite(err) or _state_status(K[12], 0, 0, np.inf) != OK:
                istats[S_REJECTED] += 1
                h *= 0.1
                rejected_last = True
                continue
            if err > 1.0:
                istats[S_REJECTED] += 1
                h *= max(0.2, 0.9 * err ** (-1.0 / 8.0))
                rejected_last = True
                continue
            fac = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
            hnew = h * (min(1.0, fac) if rejected_last else fac)
            accepted = True
            acc_mode = DOP853
        elif mode == RK45:
            # ---- one Dormand-Prince attempt: stages 2-7 (stage 7 is the new point, FSAL)
            for s in range(1, 7):
                for r in range(n):
                    acc = 0.0
                    for q in range(s):
                        acc += DP_A7[s, q] * K[q, r]
                    zs[r] = z[r] + h * acc
                if s == 5:
                    y6[:] = zs
                problem_rhs(p, t + DP_C7[s] * h, zs, K[s])
            istats[S_NFEV] += 6
            znew[:] = zs
            for r in range(n):
                acc = 0.0
                for q in range(7):
                    acc += DP_E[q] * K[q, r]
                errv[r] = h * acc
            err = scaled_rms(errv, z, znew, mag, ne, rtol, atol)
            if not np.isfinite(err) or _state_status(K[6], 0, 0, np.inf) != OK:
                istats[S_REJECTED] += 1
                h *= 0.1
                rejected_last = True
                continue
            # PI step-size control ([HNW] IV.2, DOPRI5 with beta = 0.04)
            fac11 = err ** (0.2 - 0.04 * 0.75)
            if err > 1.0:
                istats[S_REJECTED] += 1
                h = h / min(5.0, fac11 / 0.9)
                rejected_last = True
                continue
            fac = max(0.1, min(5.0, fac11 / errold ** 0.04 / 0.9))  # 1/fac in [0.2, 10]
            errold = max(err, 1e-4)
            hnew = h / fac
            if rejected_last:
                hnew = min(hnew, h)
            accepted = True
            # stiffness detection: h |lambda| ~ h ||k7 - k6|| / ||y7 - y6||
            stnum = 0.0
            stden = 0.0
            for r in range(ne):
                stnum += (K[6, r] - K[5, r]) ** 2
                stden += (znew[r] - y6[r]) ** 2
            if stden > 0.0:
                hlamb = h * np.sqrt(stnum / stden)
                if hlamb > 3.25:
                    nonsti = 0
                    iasti += 1
                    istats[S_STIFF_HITS] += 1
                    if iasti == 15:
                        if not fstats[FS_STIFF_T] >= 0:
                            fstats[FS_STIFF_T] = tn
                        if method == AUTO and istats[S_NSWITCH] < MAX_SWITCHES:
                            k = istats[S_NSWITCH]
                            switch_log[k, 0] = tn
                            switch_log[k, 1] = RADAU
                            switch_log[k, 2] = SWITCH_STIFF
                            switch_log[k, 3] = hlamb
                            istats[S_NSWITCH] += 1
                            mode = RADAU
                            need_jac = True
                            have_lu = False
                            have_sol = False
                            h_abs_old = -1.0
                            err_norm_old = -1.0
                            nonstiff_count = 0
                else:
                    nonsti += 1
                    if nonsti == 6:
                        iasti = 0
            acc_mode = RK45
        else:
            # ---- one Radau IIA attempt
            converged = False
            n_iter = 0
            rate = -1.0
            while True:
                if need_jac:
                    fd_jacobian(p, t, z, K[0], mag, ne, J, istats)
                    rho = spectral_radius(J, ne)
                    need_jac = False
                    current_jac = True
                    have_lu = False
                mr = RA_MU_REAL / h
                mc = complex(RA_MU_CRE, RA_MU_CIM) / h
                if not have_lu:
                    for r in range(n):
                        for c in range(n):
                            LUr[r, c] = -J[r, c]
                            LUc[r, c] = -J[r, c]
                        LUr[r, r] += mr
                        LUc[r, r] += mc
                    lu_factor(LUr, pivr)
                    lu_factor(LUc, pivc)
                    istats[S_NLU] += 2
                    have_lu = True
                # initial guess: the last step's collocation polynomial (increments are chart-free to
                # first order), else zero
                if have_sol:
                    for s in range(3):
                        x1 = 1.0 + RA_C[s] * h / h_sol
                        for r in range(n):
                            Z[s, r] = (Qd[r, 0] * (x1 - 1.0) + Qd[r, 1] * (x1 * x1 - 1.0)
                                       + Qd[r, 2] * (x1 * x1 * x1 - 1.0))
                else:
                    Z[:, :] = 0.0
                for s in range(3):
                    for r in range(n):
                        W[s, r] = RA_TI[s, 0] * Z[0, r] + RA_TI[s, 1] * Z[1, r] + RA_TI[s, 2] * Z[2, r]
                # simplified Newton iterations on the transformed stage system
                dW_norm_old = -1.0
                converged = False
                rate = -1.0
                n_iter = 0
                for it in range(NEWTON_MAXITER):
                    n_iter = it + 1
                    finite = True
                    for s in range(3):
                        for r in range(n):
                            zs[r] = z[r] + Z[s, r]
                        problem_rhs(p, t + RA_C[s] * h, zs, F[s])
                        if _state_status(F[s], 0, 0, np.inf) != OK:
                            finite = False
                    istats[S_NFEV] += 3
                    if not finite:
                        break
                    for r in range(n):
                        fr[r] = (RA_TI[0, 0] * F[0, r] + RA_TI[0, 1] * F[1, r] + RA_TI[0, 2] * F[2, r]
                                 - mr * W[0, r])
                        fc[r] = (complex(RA_TI[1, 0], RA_TI[2, 0]) * F[0, r]
                                 + complex(RA_TI[1, 1], RA_TI[2, 1]) * F[1, r]
                                 + complex(RA_TI[1, 2], RA_TI[2, 2]) * F[2, r]
                                 - mc * complex(W[1, r], W[2, r]))
                    dWr[:] = fr
                    dWc[:] = fc
                    lu_solve(LUr, pivr, dWr)
                    lu_solve(LUc, pivc, dWc)
                    acc = 0.0
                    for r in range(ne):
                        sc = atol + rtol * (abs(z[r]) + mag[r])
                        acc += (dWr[r] / sc) ** 2 + (dWc[r].real / sc) ** 2 + (dWc[r].imag / sc) ** 2
                    dW_norm = np.sqrt(acc / (3 * max(ne, 1)))
                    if not np.isfinite(dW_norm):
                        break
                    if dW_norm_old > 0:
                        rate = dW_norm / dW_norm_old
                    if rate >= 0 and (rate >= 1 or rate ** (NEWTON_MAXITER - it) / (1 - rate) * dW_norm
                                      > newton_tol):
                        break
                    for r in range(n):
                        W[0, r] += dWr[r]
                        W[1, r] += dWc[r].real
                        W[2, r] += dWc[r].imag
                    for s in range(3):
                        for r in range(n):
                            Z[s, r] = RA_T[s, 0] * W[0, r] + RA_T[s, 1] * W[1, r] + RA_T[s, 2] * W[2, r]
                    if dW_norm == 0 or (rate >= 0 and rate / (1 - rate) * dW_norm < newton_tol):
                        converged = True
                        break
                    dW_norm_old = dW_norm
                if converged or current_jac:
                    break
                need_jac = True  # retry once with a fresh Jacobian
            if not converged:
                istats[S_REJECTED] += 1
                h *= 0.5
                have_lu = False
                rejected_last = True
                continue
            for r in range(n):
                znew[r] = z[r] + Z[2, r]
            # embedded error estimate, filtered ([HW] IV.8, eq. 8.20): err = (mu_real/h - J)^-1 (f0 + Z^T E / h)
            for r in range(n):
                errv[r] = K[0, r] + (Z[0, r] * RA_E[0] + Z[1, r] * RA_E[1] + Z[2, r] * RA_E[2]) / h
            lu_solve(LUr, pivr, errv)
            err = scaled_rms(errv, z, znew, mag, ne, rtol, atol)
            safety = 0.9 * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + n_iter)
            if not np.isfinite(err):
                istats[S_REJECTED] += 1
                h *= 0.25
                have_lu = False
                rejected_last = True
                continue
            # Gustafsson's predictive controller ([HW] IV.8, eq. 8.25)
            if err_norm_old < 0 or h_abs_old < 0 or err == 0:
                mult = 1.0
            else:
                mult = h / h_abs_old * (err_norm_old / err) ** 0.25
            factor = min(1.0, mult) * (err ** -0.25 if err > 0 else 10.0)
            if err > 1:
                istats[S_REJECTED] += 1
                h *= max(0.2, safety * factor)
                have_lu = False
                rejected_last = True
                continue
            accepted = True
            recompute_jac = n_iter > 2 and rate > 1e-3
            factor = min(10.0, safety * factor)
            if not recompute_jac and factor < 1.2:
                factor = 1.0
            else:
                have_lu = False
            h_abs_old = h
            err_norm_old = err
            hnew = h * factor
            if recompute_jac:
                need_jac = True
                current_jac = False
            else:
                current_jac = False
            for r in range(n):  # this step's dense output
                for m in range(3):
                    Qd[r, m] = Z[0, r] * RA_P[0, m] + Z[1, r] * RA_P[1, m] + Z[2, r] * RA_P[2, m]
            have_sol = True
            h_sol = h
            if rho >= 0:
                hr = h * rho
                if not fstats[FS_HRHO] >= hr:
                    fstats[FS_HRHO] = hr
            acc_mode = RADAU
            # auto: back to the explicit method when it would be stable at this step size
            if method == AUTO and rho >= 0:
                if h * rho < 2.0:
                    nonstiff_count += 1
                else:
                    nonstiff_count = 0
                if nonstiff_count >= 20 and istats[S_NSWITCH] < MAX_SWITCHES:
                    k = istats[S_NSWITCH]
                    switch_log[k, 0] = tn
                    switch_log[k, 1] = RK45
                    switch_log[k, 2] = SWITCH_NONSTIFF
                    switch_log[k, 3] = h * rho
                    istats[S_NSWITCH] += 1
                    mode = RK45
                    iasti = 0
                    nonsti = 0
                    errold = 1e-4
                    hnew = h
                    need_jac = True

        # ---- accepted (any method)
        rejected_last = False
        fresh = True
        dense_ready = False
        st = _state_status(znew, nc, nvel, blowup)
        local_err += _max_abs(errv, ne)
        istats[S_STEPS] += 1
        zs[:] = z  # start of the step, for the dense output
        z[:] = znew
        t = tn
        h_acc = h
        h = hnew
        if acc_mode == RADAU:  # f at the new point (Radau is not FSAL)
            problem_rhs(p, t, z, K[0])
            istats[S_NFEV] += 1
        if st != OK:
            status = st
            break
    istats[S_STATUS] = status
    fstats[FS_T] = t
    fstats[FS_LOCAL_ERR] = local_err
    fstats[FS_H] = h
    return status
