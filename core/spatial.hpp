// Spatial algebra in one place (Featherstone, Rigid Body Dynamics Algorithms, 2008, ch. 2).
//
// Conventions of every kernel in core/:
//  * A spatial motion is Motion{w, v}: angular velocity and the linear velocity of the point at the frame
//    origin, in the frame's coordinates (Featherstone's order, angular first).  A spatial force is
//    Force{n, f}: moment about the frame origin and force.  This is the only order inside the core; the
//    public API's [linear; angular] rows and [force, torque] rows are converted by to_api / force_from_api
//    below, and nowhere else.
//  * A transform from a child frame B to its parent P is Transform{R, p}: R = P_R_B (columns are B's axes
//    in P), p = B's origin in P.  Motion P -> B: w_B = R^T w_P, v_B = R^T (v_P + w_P x p).
//    Force B -> P: f_P = R f_B, n_P = R n_B + p x (R f_B) (eqs. 2.24-2.25 with X* = X^-T).
//  * A rigid-body inertia about the frame origin is Inertia{m, h, Io}: mass, first moment h = m c and the
//    rotational inertia about the origin Io = Ic + m [c]x^T [c]x; its 6x6 form (angular first) is
//    [[Io, [h]x], [[h]x^T, m 1]] (eq. 2.63).
//
// Every expression keeps the order of operations of the textbook formula as written (the build has
// -ffp-contract=off and no -ffast-math), so a state gives the same bits alone, in a batch or in a simulation.
#pragma once

#include <cmath>

namespace core {

struct Vec3 {
    double x = 0.0, y = 0.0, z = 0.0;
    double operator[](int k) const { return k == 0 ? x : (k == 1 ? y : z); }
};

inline Vec3 operator+(const Vec3& a, const Vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator-(const Vec3& a) { return {-a.x, -a.y, -a.z}; }
inline Vec3 operator*(double s, const Vec3& a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// A 3x3 matrix, row-major.
struct Mat3 {
    double m[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    double operator[](int k) const { return m[k]; }
    double& operator[](int k) { return m[k]; }
    static Mat3 identity() { return {{1, 0, 0, 0, 1, 0, 0, 0, 1}}; }
};

// R x
inline Vec3 rot(const Mat3& R, const Vec3& x) {
    return {R[0] * x.x + R[1] * x.y + R[2] * x.z, R[3] * x.x + R[4] * x.y + R[5] * x.z,
            R[6] * x.x + R[7] * x.y + R[8] * x.z};
}
// R^T x
inline Vec3 rotT(const Mat3& R, const Vec3& x) {
    return {R[0] * x.x + R[3] * x.y + R[6] * x.z, R[1] * x.x + R[4] * x.y + R[7] * x.z,
            R[2] * x.x + R[5] * x.y + R[8] * x.z};
}
inline Mat3 operator*(const Mat3& A, const Mat3& B) {
    Mat3 C;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            C[3 * r + c] = A[3 * r] * B[c] + A[3 * r + 1] * B[3 + c] + A[3 * r + 2] * B[6 + c];
    return C;
}
inline Mat3 operator+(const Mat3& A, const Mat3& B) {
    Mat3 C;
    for (int k = 0; k < 9; ++k) C[k] = A[k] + B[k];
    return C;
}
inline Mat3 transpose(const Mat3& A) { return {{A[0], A[3], A[6], A[1], A[4], A[7], A[2], A[5], A[8]}}; }
// R X R^T
inline Mat3 rot_congruence(const Mat3& R, const Mat3& X) { return (R * X) * transpose(R); }
// [a]x, the cross-product matrix
inline Mat3 skew(const Vec3& a) { return {{0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0}}; }

struct Motion {
    Vec3 w, v;
};
struct Force {
    Vec3 n, f;
};

inline Motion operator+(const Motion& a, const Motion& b) { return {a.w + b.w, a.v + b.v}; }
inline Motion operator-(const Motion& a, const Motion& b) { return {a.w - b.w, a.v - b.v}; }
inline Motion operator*(double s, const Motion& a) { return {s * a.w, s * a.v}; }
inline Force operator+(const Force& a, const Force& b) { return {a.n + b.n, a.f + b.f}; }
inline Force operator-(const Force& a, const Force& b) { return {a.n - b.n, a.f - b.f}; }
inline Force operator*(double s, const Force& a) { return {s * a.n, s * a.f}; }

// The pairing of a motion and a force, m . f (or of two 6-vectors).
inline double dot(const Motion& m, const Force& f) {
    return m.w.x * f.n.x + m.w.y * f.n.y + m.w.z * f.n.z + m.v.x * f.f.x + m.v.y * f.f.y + m.v.z * f.f.z;
}
// m1 x m2 = (w1 x w2, w1 x v2 + v1 x w2)   (eq. 2.31)
inline Motion cross(const Motion& a, const Motion& b) { return {cross(a.w, b.w), cross(a.w, b.v) + cross(a.v, b.w)}; }
// m x* f = (w x n + v x f, w x f)   (eq. 2.32)
inline Force cross(const Motion& m, const Force& f) { return {cross(m.w, f.n) + cross(m.v, f.f), cross(m.w, f.f)}; }

// Body B in its parent P: R = P_R_B, p = B's origin in P.
struct Transform {
    Mat3 R = Mat3::identity();
    Vec3 p;
};

// X m: the parent's motion in the child frame.
inline Motion motion_to_child(const Transform& X, const Motion& m) {
    return {rotT(X.R, m.w), rotT(X.R, m.v + cross(m.w, X.p))};
}
// X^-1 m: the child's motion in the parent frame (Pinocchio's act).
inline Motion motion_to_parent(const Transform& X, const Motion& m) {
    Vec3 wP = rot(X.R, m.w);
    return {wP, rot(X.R, m.v) + cross(X.p, wP)};
}
// X^T f: the child's force in the parent frame.
inline Force force_to_parent(const Transform& X, const Force& f) {
    Vec3 fP = rot(X.R, f.f);
    return {rot(X.R, f.n) + cross(X.p, fP), fP};
}
// The composition A B: frame C in A's parent, given B = C in A and A.
inline Transform compose(const Transform& A, const Transform& B) { return {A.R * B.R, rot(A.R, B.p) + A.p}; }

struct Inertia {
    double m = 0.0;
    Vec3 h;
    Mat3 Io;
};

// I m = (Io w + h x v, m v - h x w)
inline Force operator*(const Inertia& I, const Motion& a) {
    Vec3 n = rot(I.Io, a.w) + cross(I.h, a.v);
    Vec3 hw = cross(I.h, a.w);
    return {n, {I.m * a.v.x - hw.x, I.m * a.v.y - hw.y, I.m * a.v.z - hw.z}};
}

// The inertia of a child frame expressed about its parent's origin.  With r' = R r + p for every mass point:
// h' = R h + m p and Io' = R Io R^T + (2 p.(R h) + m |p|^2) 1 - ((R h) p^T + p (R h)^T + m p p^T).
inline Inertia inertia_to_parent(const Transform& X, const Inertia& I) {
    const Vec3& p = X.p;
    Vec3 hR = rot(X.R, I.h);
    Mat3 A = rot_congruence(X.R, I.Io);
    double m = I.m;
    double d = 2.0 * dot(p, hR) + m * dot(p, p);
    Mat3 out = {{A[0] + d - 2.0 * hR.x * p.x - m * p.x * p.x, A[1] - hR.x * p.y - p.x * hR.y - m * p.x * p.y,
                 A[2] - hR.x * p.z - p.x * hR.z - m * p.x * p.z, A[3] - hR.y * p.x - p.y * hR.x - m * p.y * p.x,
                 A[4] + d - 2.0 * hR.y * p.y - m * p.y * p.y, A[5] - hR.y * p.z - p.y * hR.z - m * p.y * p.z,
                 A[6] - hR.z * p.x - p.z * hR.x - m * p.z * p.x, A[7] - hR.z * p.y - p.z * hR.y - m * p.z * p.y,
                 A[8] + d - 2.0 * hR.z * p.z - m * p.z * p.z}};
    return {m, hR + m * p, out};
}

// A 6x6 matrix (an articulated-body inertia), row-major, (angular, linear) blocks.
struct Mat6 {
    double a[36];
    double operator()(int r, int c) const { return a[6 * r + c]; }
    double& operator()(int r, int c) { return a[6 * r + c]; }
};

// The 6x6 form of a rigid-body inertia, [[Io, [h]x], [[h]x^T, m 1]] (eq. 2.63).
inline Mat6 to_matrix(const Inertia& I) {
    Mat6 M;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            M(r, c) = I.Io[3 * r + c];
            M(3 + r, 3 + c) = r == c ? I.m : 0.0;
        }
    Mat3 hx = skew(I.h);
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            M(r, 3 + c) = hx[3 * r + c];
            M(3 + c, r) = hx[3 * r + c];
        }
    return M;
}

// A 6-vector as 6 doubles in the core's order (angular first), for the 6x6 products.
inline void to_array(const Motion& m, double* x) {
    x[0] = m.w.x, x[1] = m.w.y, x[2] = m.w.z, x[3] = m.v.x, x[4] = m.v.y, x[5] = m.v.z;
}
inline void to_array(const Force& f, double* x) {
    x[0] = f.n.x, x[1] = f.n.y, x[2] = f.n.z, x[3] = f.f.x, x[4] = f.f.y, x[5] = f.f.z;
}
inline Motion motion_from(const double* x) { return {{x[0], x[1], x[2]}, {x[3], x[4], x[5]}}; }
inline Force force_from(const double* x) { return {{x[0], x[1], x[2]}, {x[3], x[4], x[5]}}; }

// The public API's order: rows [linear; angular] (Pinocchio's) for motions, [force, torque] for forces.  The
// only two places that convert; `stride` steps between the six outputs (a column of a (6, n) matrix).
inline void to_api(const Motion& m, double* out, long stride = 1) {
    out[0] = m.v.x, out[stride] = m.v.y, out[2 * stride] = m.v.z;
    out[3 * stride] = m.w.x, out[4 * stride] = m.w.y, out[5 * stride] = m.w.z;
}
inline Force force_from_api(const double* x) { return {{x[3], x[4], x[5]}, {x[0], x[1], x[2]}}; }

// -- rotations -----------------------------------------------------------------------------------------------

// The rotation of the quaternion (x, y, z, w), normalised first (Hamilton).
inline Mat3 quaternion_rotation(double qx, double qy, double qz, double qw) {
    double nrm = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
    double x = qx / nrm, y = qy / nrm, z = qz / nrm, w = qw / nrm;
    return {{1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w), 2.0 * (x * y + z * w),
             1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w), 2.0 * (x * z - y * w), 2.0 * (y * z + x * w),
             1.0 - 2.0 * (x * x + y * y)}};
}

struct Quaternion {
    double x, y, z, w;
};
// Hamilton product a * b of quaternions (x, y, z, w).
inline Quaternion operator*(const Quaternion& a, const Quaternion& b) {
    return {a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y, a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
            a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w, a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z};
}
// The unit quaternion of the rotation vector w (exp map), accurate near zero.
inline Quaternion quaternion_exp(const Vec3& t) {
    double th2 = t.x * t.x + t.y * t.y + t.z * t.z;
    double s, c;
    if (th2 < 1e-12) {
        s = 0.5 - th2 / 48.0;  // sin(th/2)/th by its Taylor series
        c = 1.0 - th2 / 8.0;
    } else {
        double th = std::sqrt(th2);
        s = std::sin(0.5 * th) / th;
        c = std::cos(0.5 * th);
    }
    return {s * t.x, s * t.y, s * t.z, c};
}
// R(quat) a for a unit quaternion: a + 2 w (u x a) + 2 u x (u x a), u = (x, y, z).
inline Vec3 quaternion_rotate(const Quaternion& q, const Vec3& a) {
    double c0 = q.y * a.z - q.z * a.y, c1 = q.z * a.x - q.x * a.z, c2 = q.x * a.y - q.y * a.x;
    return {a.x + 2.0 * (q.w * c0 + q.y * c2 - q.z * c1), a.y + 2.0 * (q.w * c1 + q.z * c0 - q.x * c2),
            a.z + 2.0 * (q.w * c2 + q.x * c1 - q.y * c0)};
}
// (1 + a [t] + b [t]^2) x
inline Vec3 skew_poly(double a, double b, const Vec3& t, const Vec3& x) {
    Vec3 c = cross(t, x);
    Vec3 d = cross(t, c);
    return {x.x + a * c.x + b * d.x, x.y + a * c.y + b * d.y, x.z + a * c.z + b * d.z};
}

// The rotation vector theta * axis of R, log: SO(3) -> R^3, accurate near 0 and near pi.
Vec3 rotation_log(const Mat3& R);

// Dinv = the inverse of the symmetric positive definite n x n matrix D (row-major, leading dimension 6), by
// Gauss-Jordan without pivoting (valid for SPD).  False when a pivot is not positive.
bool spd_inverse(const double* D, int n, double* Dinv);

}  // namespace core
