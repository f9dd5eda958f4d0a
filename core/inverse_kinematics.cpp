// Damped least-squares inverse kinematics (inverse_kinematics.hpp has the method).
#include "inverse_kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "configuration.hpp"
#include "jacobians.hpp"
#include "joints.hpp"
#include "kinematics.hpp"

namespace core {

namespace {

// e = [p_d - p; log(R_d R^T)]; returns the position and orientation errors' norms.
std::pair<double, double> pose_error(const Transform& target, const Transform& T, double* e) {
    e[0] = target.p.x - T.p.x, e[1] = target.p.y - T.p.y, e[2] = target.p.z - T.p.z;
    const Vec3 w = rotation_log(target.R * transpose(T.R));
    e[3] = w.x, e[4] = w.y, e[5] = w.z;
    return {std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]), std::sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])};
}

void clamp(const Model& model, double* q) {
    for (int i = 0; i < model.nb; ++i)
        if (joint_limited(model, i)) {
            const int k = model.v_idx[i], kq = model.q_idx[i];
            q[kq] = std::min(std::max(q[kq], model.lower[k]), model.upper[k]);
        }
}

// dq = F J^T (J F J^T + mu 1)^-1 e over the first r rows, F = diag(free).  False if not solvable.
bool dls_step(int nv, const double* J, const double* free, const double* e, int r, double mu, double* dq) {
    double A[36], Ainv[36], y[6];
    for (int a = 0; a < r; ++a)
        for (int c = a; c < r; ++c) {
            double x = a == c ? mu : 0.0;
            for (int k = 0; k < nv; ++k) x += J[a * nv + k] * free[k] * J[c * nv + k];
            A[6 * a + c] = x;
            A[6 * c + a] = x;
        }
    if (!spd_inverse(A, r, Ainv)) return false;
    for (int a = 0; a < r; ++a) {
        double x = 0.0;
        for (int c = 0; c < r; ++c) x += Ainv[6 * a + c] * e[c];
        y[a] = x;
    }
    for (int k = 0; k < nv; ++k) {
        double x = 0.0;
        for (int a = 0; a < r; ++a) x += J[a * nv + k] * y[a];
        dq[k] = free[k] * x;
    }
    return true;
}

// Freezes (free = 0) each 1-dof joint at a limit that dq pushes further out; true if any was frozen.
bool freeze_blocked(const Model& model, const double* q, const double* dq, double* free) {
    bool frozen = false;
    for (int i = 0; i < model.nb; ++i)
        if (joint_limited(model, i)) {
            const int k = model.v_idx[i], kq = model.q_idx[i];
            if (free[k] != 0.0 && ((q[kq] <= model.lower[k] && dq[k] < 0.0) || (q[kq] >= model.upper[k] && dq[k] > 0.0))) {
                free[k] = 0.0;
                frozen = true;
            }
        }
    return frozen;
}

}  // namespace

IkResult inverse_kinematics(const Model& model, Data& data, const double* q0, const Transform& target, int f, int r,
                            double tol, int max_iter, double damping, bool limits, double* q) {
    const int nv = model.nv, nq = model.nq;
    double *J = data.J.data(), *Jt = data.Jt.data(), *dq = data.tmp_v.data(), *free = data.tmp_v2.data();
    double *qt = data.tmp_q.data(), *delta = data.tmp_q2.data(), e_[6], et_[6];
    double *e = e_, *et = et_;
    std::fill(data.J.begin(), data.J.end(), 0.0);  // only the support's columns are written
    std::fill(data.Jt.begin(), data.Jt.end(), 0.0);
    std::copy(q0, q0 + nq, q);
    if (limits) clamp(model, q);
    auto [ep, eo] = pose_error(target, frame_jacobian(model, data, q, f, LOCAL_WORLD_ALIGNED, {}, J), e);
    double res = r == 6 ? std::sqrt(ep * ep + eo * eo) : ep;
    double mu = damping * damping;
    IkResult out;
    while (true) {
        if (res < tol) {
            out.status = IK_CONVERGED;
            break;
        }
        if (out.iterations >= max_iter) break;
        if (mu > IK_MAX_MU) {
            out.status = IK_STALLED;
            break;
        }
        ++out.iterations;
        std::fill(free, free + nv, 1.0);
        bool solved = true;
        for (int pass = 0; pass <= nv; ++pass) {  // with limits: again without the joints a step pushes out of them
            solved = dls_step(nv, J, free, e, r, mu, dq);
            if (!(solved && limits && freeze_blocked(model, q, dq, free))) break;
        }
        if (!solved) {
            mu = std::max(10.0 * mu, 1e-12);
            continue;
        }
        integrate(model, q, dq, 1.0, delta, qt);
        if (limits) clamp(model, qt);
        auto [tp, to] = pose_error(target, frame_jacobian(model, data, qt, f, LOCAL_WORLD_ALIGNED, {}, Jt), et);
        const double rt = r == 6 ? std::sqrt(tp * tp + to * to) : tp;
        if (rt < res) {  // accept
            const bool stalled = res - rt <= 1e-12 * res;  // no real progress: the closest pose this start leads to
            std::copy(qt, qt + nq, q);
            res = rt, ep = tp, eo = to;
            if (stalled) {
                out.status = IK_STALLED;
                break;
            }
            std::swap(J, Jt);
            std::swap(e, et);
            mu = std::max(0.1 * mu, damping * damping);
        } else {
            mu = std::max(10.0 * mu, 1e-12);
        }
    }
    out.residual = res, out.position_error = ep, out.orientation_error = eo;
    return out;
}

}  // namespace core
