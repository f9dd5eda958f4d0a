// Joint models: one switch on the joint type per function (joints.hpp has the conventions).
#include "joints.hpp"

#include <cmath>

namespace core {

int joint_nq(int type) {
    switch (type) {
        case JOINT_FREE: return 7;
        case JOINT_SPHERICAL: return 4;
        case JOINT_PLANAR: return 4;
        default: return 1;
    }
}

int joint_nv(int type) {
    switch (type) {
        case JOINT_FREE: return 6;
        case JOINT_SPHERICAL: return 3;
        case JOINT_PLANAR: return 3;
        default: return 1;
    }
}

void joint_neutral(int type, double* q0) {
    for (int k = 0; k < joint_nq(type); ++k) q0[k] = 0.0;
    switch (type) {
        case JOINT_FREE: q0[6] = 1.0; break;       // [x, y, z, qx, qy, qz, qw]
        case JOINT_SPHERICAL: q0[3] = 1.0; break;  // [qx, qy, qz, qw]
        case JOINT_PLANAR: q0[2] = 1.0; break;     // [x, y, cos 0, sin 0]
        default: break;
    }
}

static double quaternion_sq(const double* q) { return q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]; }

bool joint_config_ok(const Model& model, int i, const double* q) {
    const double* x = q + model.q_idx[i];
    switch (model.jtype[i]) {
        case JOINT_FREE: return quaternion_sq(x + 3) >= ZERO_QUATERNION_SQ;
        case JOINT_SPHERICAL: return quaternion_sq(x) >= ZERO_QUATERNION_SQ;
        case JOINT_PLANAR: return x[2] * x[2] + x[3] * x[3] >= ZERO_QUATERNION_SQ;
        default: return true;
    }
}

// -- the configuration manifold ------------------------------------------------------------------------------

// (a, b) of V(theta) = 1 + a [theta] + b [theta]^2, the SE(3) exponential's translation term.
static void se3_v(const Vec3& t, double& a, double& b) {
    double phi2 = t.x * t.x + t.y * t.y + t.z * t.z;
    if (phi2 < 1e-8) {  // by its series
        a = 0.5 - phi2 / 24.0, b = 1.0 / 6.0 - phi2 / 120.0;
        return;
    }
    double phi = std::sqrt(phi2);
    a = (1.0 - std::cos(phi)) / phi2, b = (phi - std::sin(phi)) / (phi2 * phi);
}

// c of Jr(theta)^-1 = 1 + [theta]/2 + c [theta]^2 (and of V(theta)^-1 = 1 - [theta]/2 + c [theta]^2).
static double so3_jr_inv(const Vec3& t) {
    double phi2 = t.x * t.x + t.y * t.y + t.z * t.z;
    if (phi2 < 1e-8) return 1.0 / 12.0 + phi2 / 720.0;
    double phi = std::sqrt(phi2);
    return 1.0 / phi2 - (1.0 + std::cos(phi)) / (2.0 * phi * std::sin(phi));
}

static Quaternion quaternion_at(const double* q) { return {q[0], q[1], q[2], q[3]}; }
static Quaternion normalised(const double* q) {
    double nrm = std::sqrt(quaternion_sq(q));
    return {q[0] / nrm, q[1] / nrm, q[2] / nrm, q[3] / nrm};
}

// (cos theta, sin theta) of a planar joint, normalised.
static void unit2(const double* q, double& c, double& s) {
    double n = std::sqrt(q[0] * q[0] + q[1] * q[1]);
    c = q[0] / n, s = q[1] / n;
}

void joint_integrate_delta(const Model& model, int i, const double* q, const double* v, double dt, double* delta) {
    const int k = model.v_idx[i], kq = model.q_idx[i];
    switch (model.jtype[i]) {
        case JOINT_REVOLUTE:
        case JOINT_PRISMATIC: delta[k] = v[k] * dt; return;
        case JOINT_SPHERICAL:
            delta[k] = v[k] * dt, delta[k + 1] = v[k + 1] * dt, delta[k + 2] = v[k + 2] * dt;
            return;
        case JOINT_PLANAR: {  // the SE(2) exponential, V2 = [[sin t, -(1 - cos t)], [1 - cos t, sin t]] / t
            double t = v[k + 2] * dt, a, b;
            if (std::abs(t) < 1e-4) {  // sin t / t and (1 - cos t) / t by their series
                a = 1.0 - t * t / 6.0 * (1.0 - t * t / 20.0), b = t / 2.0 * (1.0 - t * t / 12.0);
            } else {
                a = std::sin(t) / t, b = (1.0 - std::cos(t)) / t;
            }
            double x = (a * v[k] - b * v[k + 1]) * dt, y = (b * v[k] + a * v[k + 1]) * dt, c, s;
            unit2(q + kq + 2, c, s);
            delta[k] = c * x - s * y, delta[k + 1] = s * x + c * y, delta[k + 2] = t;
            return;
        }
        default: {  // the SE(3) exponential: (R V(theta) v_lin dt, theta = omega dt)
            Vec3 t = {v[k + 3] * dt, v[k + 4] * dt, v[k + 5] * dt};
            double a, b;
            se3_v(t, a, b);
            Vec3 x = skew_poly(a, b, t, {v[k] * dt, v[k + 1] * dt, v[k + 2] * dt});
            Vec3 p = quaternion_rotate(normalised(q + kq + 3), x);
            delta[k] = p.x, delta[k + 1] = p.y, delta[k + 2] = p.z;
            delta[k + 3] = t.x, delta[k + 4] = t.y, delta[k + 5] = t.z;
        }
    }
}

// q[0..4) = q0[0..4) (x) exp(d), renormalised.
static void retract_quaternion(const double* q0, const Vec3& d, double* q) {
    Quaternion r = quaternion_at(q0) * quaternion_exp(d);
    double nrm = std::sqrt(r.x * r.x + r.y * r.y + r.z * r.z + r.w * r.w);
    q[0] = r.x / nrm, q[1] = r.y / nrm, q[2] = r.z / nrm, q[3] = r.w / nrm;
}

void joint_retract(const Model& model, int i, const double* q0, const double* delta, double* q) {
    const int k = model.v_idx[i], kq = model.q_idx[i];
    switch (model.jtype[i]) {
        case JOINT_REVOLUTE:
        case JOINT_PRISMATIC: q[kq] = q0[kq] + delta[k]; return;
        case JOINT_SPHERICAL: retract_quaternion(q0 + kq, {delta[k], delta[k + 1], delta[k + 2]}, q + kq); return;
        case JOINT_PLANAR: {
            q[kq] = q0[kq] + delta[k], q[kq + 1] = q0[kq + 1] + delta[k + 1];
            double c0, s0;
            unit2(q0 + kq + 2, c0, s0);
            double cd = std::cos(delta[k + 2]), sd = std::sin(delta[k + 2]);
            double c = c0 * cd - s0 * sd, s = s0 * cd + c0 * sd;
            double nrm = std::sqrt(c * c + s * s);
            q[kq + 2] = c / nrm, q[kq + 3] = s / nrm;
            return;
        }
        default:
            for (int r = 0; r < 3; ++r) q[kq + r] = q0[kq + r] + delta[k + r];
            retract_quaternion(q0 + kq + 3, {delta[k + 3], delta[k + 4], delta[k + 5]}, q + kq + 3);
    }
}

// out[0..3) = log(quat0^-1 quat1), the shorter way round.
static void quaternion_log(const double* q0, const double* q1, double* out) {
    Quaternion r = Quaternion{-q0[0], -q0[1], -q0[2], q0[3]} * quaternion_at(q1);
    if (r.w < 0.0) r = {-r.x, -r.y, -r.z, -r.w};
    double s = std::sqrt(r.x * r.x + r.y * r.y + r.z * r.z);
    double ang = 2.0 * std::atan2(s, r.w);
    double f = s < 1e-12 ? 2.0 / r.w : ang / s;
    out[0] = f * r.x, out[1] = f * r.y, out[2] = f * r.z;
}

// theta1 - theta0 in (-pi, pi] from the (cos, sin) pairs at q0, q1.
static double planar_angle(const double* q0, const double* q1) {
    return std::atan2(q0[0] * q1[1] - q0[1] * q1[0], q0[0] * q1[0] + q0[1] * q1[1]);
}

void joint_difference(const Model& model, int i, const double* q0, const double* q1, double* out) {
    const int k = model.v_idx[i], kq = model.q_idx[i];
    switch (model.jtype[i]) {
        case JOINT_REVOLUTE:
        case JOINT_PRISMATIC: out[k] = q1[kq] - q0[kq]; return;
        case JOINT_SPHERICAL: quaternion_log(q0 + kq, q1 + kq, out + k); return;
        case JOINT_PLANAR:
            out[k] = q1[kq] - q0[kq], out[k + 1] = q1[kq + 1] - q0[kq + 1];
            out[k + 2] = planar_angle(q0 + kq + 2, q1 + kq + 2);
            return;
        default:
            for (int r = 0; r < 3; ++r) out[k + r] = q1[kq + r] - q0[kq + r];
            quaternion_log(q0 + kq + 3, q1 + kq + 3, out + k + 3);
    }
}

void joint_log(const Model& model, int i, const double* q0, const double* q1, double* out) {
    const int code = model.jtype[i];
    if (code != JOINT_FREE && code != JOINT_PLANAR) {
        joint_difference(model, i, q0, q1, out);
        return;
    }
    const int k = model.v_idx[i], kq = model.q_idx[i];
    double d0 = q1[kq] - q0[kq], d1 = q1[kq + 1] - q0[kq + 1], d2 = q1[kq + 2] - q0[kq + 2];
    if (code == JOINT_PLANAR) {  // the SE(2) log: ([[a, b], [-b, a]] R0^T (p1 - p0), theta)
        double t = planar_angle(q0 + kq + 2, q1 + kq + 2), c, s;
        unit2(q0 + kq + 2, c, s);
        double x = c * d0 + s * d1, y = -s * d0 + c * d1;
        double a = std::abs(t) < 1e-4 ? 1.0 - t * t / 12.0 : 0.5 * t * std::sin(t) / (1.0 - std::cos(t));
        double b = 0.5 * t;
        out[k] = a * x + b * y, out[k + 1] = -b * x + a * y, out[k + 2] = t;
        return;
    }
    // log6(M0^-1 M1) = (V(theta)^-1 R0^T (p1 - p0), theta)
    quaternion_log(q0 + kq + 3, q1 + kq + 3, out + k + 3);
    Vec3 t = {out[k + 3], out[k + 4], out[k + 5]};
    Quaternion r0 = normalised(q0 + kq + 3);
    Vec3 x = quaternion_rotate({-r0.x, -r0.y, -r0.z, r0.w}, {d0, d1, d2});
    Vec3 y = skew_poly(-0.5, so3_jr_inv(t), t, x);
    out[k] = y.x, out[k + 1] = y.y, out[k + 2] = y.z;
}

// out[0..3) = Jr(delta_theta)^-1 omega.
static void chart_rate_rotation(const double* delta, const double* w, double* out) {
    const Vec3 t = {delta[0], delta[1], delta[2]};
    const Vec3 r = skew_poly(0.5, so3_jr_inv(t), t, {w[0], w[1], w[2]});
    out[0] = r.x, out[1] = r.y, out[2] = r.z;
}

void joint_chart_rate(const Model& model, int i, const double* q, const double* delta, const double* v, double* out) {
    const int k = model.v_idx[i], kq = model.q_idx[i];
    switch (model.jtype[i]) {
        case JOINT_REVOLUTE:
        case JOINT_PRISMATIC: out[k] = v[k]; return;
        case JOINT_SPHERICAL: chart_rate_rotation(delta + k, v + k, out + k); return;
        case JOINT_PLANAR: {
            double c, s;
            unit2(q + kq + 2, c, s);
            out[k] = c * v[k] - s * v[k + 1], out[k + 1] = s * v[k] + c * v[k + 1], out[k + 2] = v[k + 2];
            return;
        }
        default: {
            const Vec3 p = quaternion_rotate(quaternion_at(q + kq + 3), {v[k], v[k + 1], v[k + 2]});
            out[k] = p.x, out[k + 1] = p.y, out[k + 2] = p.z;
            chart_rate_rotation(delta + k + 3, v + k + 3, out + k + 3);
        }
    }
}

void joint_magnitudes(const Model& model, int i, const double* q, double* mag) {
    const int k = model.v_idx[i], kq = model.q_idx[i], code = model.jtype[i];
    if (code == JOINT_FREE || code == JOINT_PLANAR) {
        const int n = code == JOINT_FREE ? 3 : 2;
        for (int r = 0; r < model.nv_j[i]; ++r) mag[k + r] = r < n ? std::abs(q[kq + r]) : 0.0;
    } else if (code == JOINT_SPHERICAL) {
        mag[k] = mag[k + 1] = mag[k + 2] = 0.0;
    } else {
        mag[k] = std::abs(q[kq]);
    }
}

}  // namespace core
