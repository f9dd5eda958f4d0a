// The force law and the body wrenches (forces.hpp; every expression in the order of dynamics/contact/forces.py, so
// that the two give the same bits).
#include "contact/forces.hpp"

#include <algorithm>
#include <cmath>

namespace core::contact {

double friction_coefficient(double s, double mu_s, double mu_d) {
    if (s >= 3.0) return mu_d;
    if (s >= 1.0) {
        const double x = 0.5 * (s - 1.0);
        return mu_s - (mu_s - mu_d) * x * x * x * (10.0 + x * (6.0 * x - 15.0));
    }
    return mu_s * s * (2.0 - s);
}

double friction_ratio(double speed, const double* mat) {
    const double vs = mat[K_VS];
    if (speed < vs) return mat[K_MU_S] * (2.0 - speed / vs) / vs;
    return friction_coefficient(speed / vs, mat[K_MU_S], mat[K_MU_D]) / speed;
}

ContactForce contact_force(const Vec3& n, double x, const Vec3& vrel, const double* mat) {
    const double vn = dot(n, vrel);
    const double fn = mat[K_STIFF] * x * std::max(0.0, 1.0 - mat[K_DISS] * vn);
    const Vec3 vt{vrel.x - vn * n.x, vrel.y - vn * n.y, vrel.z - vn * n.z};
    const double speed = std::sqrt(dot(vt, vt));
    const double c = friction_ratio(speed, mat);
    return {fn, (-c * fn) * vt, vt};
}

Vec3 point_velocity(const Transform* oMi, const Motion* vb, int64_t body, const Vec3& P) {
    if (body < 0) return {};
    const Mat3& R = oMi[body].R;
    const Vec3 r = rotT(R, P - oMi[body].p);
    return rot(R, vb[body].v + cross(vb[body].w, r));
}

namespace {
// Body `body`'s wrench += the world force F at the world point P, in its frame about its origin.
void add_wrench(const Transform* oMi, Force* fb, int64_t body, const Vec3& P, const Vec3& F) {
    if (body < 0) return;
    const Mat3& R = oMi[body].R;
    fb[body].f = fb[body].f + rotT(R, F);
    fb[body].n = fb[body].n + rotT(R, cross(P - oMi[body].p, F));
}
}  // namespace

double apply_contacts(int64_t n, const ContactBuffer& buf, const int64_t* pair_body, const double* mat,
                      const Transform* oMi, const Motion* vb, Force* fb, double* detail) {
    double power = 0.0;
    for (int64_t k = 0; k < n; ++k) {
        const int64_t j = buf.pair[k], ba = pair_body[2 * j], bb = pair_body[2 * j + 1];
        const Vec3 &P = buf.point[k], &nrm = buf.normal[k];
        const Vec3 vrel = point_velocity(oMi, vb, ba, P) - point_velocity(oMi, vb, bb, P);
        const double* m = mat + NMAT * j;
        const ContactForce c = contact_force(nrm, buf.depth[k], vrel, m);
        const Vec3 F = c.fn * nrm + c.ft;
        power += dot(F, vrel);
        add_wrench(oMi, fb, ba, P, F);
        add_wrench(oMi, fb, bb, P, -F);
        double* d = detail + NDETAIL * k;
        d[D_FN] = c.fn;
        for (int r = 0; r < 3; ++r) d[D_FT + r] = c.ft[r], d[D_SLIP + r] = c.vt[r];
        d[D_ELASTIC] = 0.5 * m[K_STIFF] * buf.depth[k] * buf.depth[k];
    }
    return power;
}

void generalized_forces(const Model& model, const Transform* X, Force* fb, double* tau) {
    for (int i = model.nb - 1; i >= 0; --i) {
        const Vec3 &f = fb[i].f, &t = fb[i].n;
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) {
            const Motion& S = model.S[k];
            tau[k] += S.w.x * t.x + S.w.y * t.y + S.w.z * t.z + S.v.x * f.x + S.v.y * f.y + S.v.z * f.z;
        }
        const int par = model.parents[i];
        if (par >= 0) {
            const Force fP = force_to_parent(X[i], fb[i]);
            fb[par].f = fb[par].f + fP.f;
            fb[par].n = fb[par].n + fP.n;
        }
    }
}

void world_poses(const Model& model, const Transform* X, Transform* oMi) {
    for (int i = 0; i < model.nb; ++i) {
        const int par = model.parents[i];
        oMi[i] = par < 0 ? X[i] : compose(oMi[par], X[i]);
    }
}

double contact_wrenches(const Model& model, Data& data, const double* q, const double* v, int64_t n,
                        const ContactBuffer& buf, const int64_t* pair_body, const double* mat, Transform* oMi,
                        Force* fb, double* detail, double* f_ext, double* tau) {
    forward_pass(model, data, q, v, true);
    world_poses(model, data.X.data(), oMi);
    std::fill(fb, fb + model.nb, Force{});
    const double power = apply_contacts(n, buf, pair_body, mat, oMi, data.v.data(), fb, detail);
    if (f_ext)
        for (int i = 0; i < model.nb; ++i)
            for (int r = 0; r < 3; ++r) f_ext[6 * i + r] = fb[i].f[r], f_ext[6 * i + 3 + r] = fb[i].n[r];
    generalized_forces(model, data.X.data(), fb, tau);
    return power;
}

}  // namespace core::contact
