// Compliant point contact: each contact's force and its share of every body's external wrench (the C++ side of
// dynamics/contact/forces.py, whose docstring derives the law).  For contact k between geometries a and b (point P,
// unit normal n from b towards a, penetration x > 0, world frame) and the pair's material (k, d, mu_s, mu_d, v_s):
//
//     v_rel = v_a(P) - v_b(P),   f_n = k x (1 - d n.v_rel)_+             Hunt & Crossley on a linear spring
//     v_t = v_rel - (n.v_rel) n,  f_t = -mu(|v_t| / v_s) f_n v_t / |v_t|   regularised Coulomb friction
//     mu(s) = mu_s s (2 - s) (s < 1),  mu_s - (mu_s - mu_d) step5((s - 1) / 2) (s < 3),  mu_d
//     F = f_n n + f_t on a at P, -F on b
//
// Body wrenches: f_i += [R_i^T F, R_i^T ((P - o_i) x F)] (body frame, about the body origin), and the generalised
// force tau_c = sum_i J_i^T f_i by one backward pass (Featherstone 2008, sec. 5.3).
#pragma once

#include <cstdint>

#include "contact/narrow_phase.hpp"
#include "data.hpp"
#include "model.hpp"
#include "spatial.hpp"

namespace core::contact {

// Columns of a pair's material row and of a contact's detail row (the Python side's K_* and D_* constants).
enum MaterialColumn { K_STIFF = 0, K_DISS = 1, K_MU_S = 2, K_MU_D = 3, K_VS = 4, NMAT = 5 };
enum DetailColumn { D_FN = 0, D_FT = 1, D_SLIP = 4, D_ELASTIC = 7, NDETAIL = 8 };

// mu(s) at s = slip speed / stiction velocity >= 0.
double friction_coefficient(double s, double mu_s, double mu_d);
// c = mu(s) / |v_t| at slip speed `speed` >= 0 (f_t = -c f_n v_t), without dividing by a vanishing speed.
double friction_ratio(double speed, const double* mat);

struct ContactForce {
    double fn;  // normal force (N)
    Vec3 ft;    // friction force (world)
    Vec3 vt;    // slip velocity (world, a relative to b)
};
ContactForce contact_force(const Vec3& n, double x, const Vec3& vrel, const double* mat);

// World velocity of body's material point at the world point P (zero for the world, body -1); vb: body velocities.
Vec3 point_velocity(const Transform* oMi, const Motion* vb, int64_t body, const Vec3& P);

// The forces of contacts 0..n-1 of buf (pair_body (npairs, 2), mat (npairs, NMAT)) added to the body wrenches fb
// (zeroed by the caller; Force{n: torque, f: force}, body frame); detail (n, NDETAIL) the rows of each contact.  Returns the
// contact power sum_k F_k . v_rel_k.
double apply_contacts(int64_t n, const ContactBuffer& buf, const int64_t* pair_body, const double* mat,
                      const Transform* oMi, const Motion* vb, Force* fb, double* detail);

// tau += sum_i J_i^T fb_i (one backward pass over the joint transforms X; fb is consumed: it ends as the
// subtrees' wrenches).
void generalized_forces(const Model& model, const Transform* X, Force* fb, double* tau);

// oMi = every body's world pose from the joint transforms X.
void world_poses(const Model& model, const Transform* X, Transform* oMi);

// The contacts 0..n-1 of buf at (q, v): tau += J_c^T f_c, f_ext (nb x 6, body frame, [force, torque]; may be null)
// = the body wrenches, detail their rows; data gets the forward pass, oMi the world poses, fb the subtrees'
// wrenches.  Returns the contact power.
double contact_wrenches(const Model& model, Data& data, const double* q, const double* v, int64_t n,
                        const ContactBuffer& buf, const int64_t* pair_body, const double* mat, Transform* oMi,
                        Force* fb, double* detail, double* f_ext, double* tau);

}  // namespace core::contact
