// Constrained inverse dynamics: the torques of the actuated joints that produce a motion (q, v, a) of a
// closed-loop or coupled mechanism (the C++ side of dynamics.constrained_inverse_dynamics).
//
//     M a + C v + g = S tau + J^T lambda   for some lambda,   S = diag(actuated)
//
// requires J a + gamma = 0 (a satisfies the constraints).  With f = M a + C v + g (the RNEA) and P the orthogonal
// projector onto null(J) (the motions the loops allow; J^T lambda is what P removes), tau solves P S tau = P f,
// the minimum-norm solution when several do.  No normal equations (they square J's condition number): P from an
// orthonormal basis U of J's row space, P x = x - U^T (U x) (modified Gram-Schmidt, each row orthogonalised twice,
// rows left below 1e-9 of the largest row's norm dropped as dependent: numpy's SVD rank at 1e-9 of the largest
// singular value in the numba version); then the columns P e_k of the actuated coordinates orthonormalised the same
// way, W C = P S (columns left below 1e-10 of their norm are torques the loops absorb, or repeat another's), and
// tau the minimum-norm solution of C tau = W^T P f: back substitution when no column was dropped, else
// C^T (C C^T)^-1 W^T P f.
#pragma once

#include <vector>

#include "constrained_dynamics.hpp"

namespace core {

// The workspace of one state (one per call or per thread, never shared); sizes in the comments.
struct ConstrainedInverseData {
    ConstrainedData cd;                // J, phi, gamma
    std::vector<double> f, Pf, y, c;   // nv
    std::vector<double> U;             // nv x nv: an orthonormal basis of J's row space (rows), then W (rows)
    std::vector<double> W, C, CC;      // nv x nv: the actuated columns' basis (rows), C, C C^T
    std::vector<int> kept, act;        // nv
    void resize(const Model& model, const Constraints& con);
};

// Results of constrained_inverse_dynamics.
enum ConstrainedIdStatus { ID_DONE = 0, ID_VIOLATES = 1, ID_UNREACHABLE = 2 };

// tau (nv), zero at passive coordinates, at (q, v, a) with gravity; actuated (nv) is 1.0 at actuated coordinates,
// 0.0 elsewhere.  Returns ID_DONE, ID_VIOLATES (|J a + gamma| above 1e-8 of its terms' size) or ID_UNREACHABLE
// (|P S tau - P f| above 1e-8 of f's size: the actuated joints cannot produce the motion).
int constrained_inverse_dynamics(const Model& model, const Constraints& con, Data& data, ConstrainedInverseData& w,
                                 const double* q, const double* v, const double* a, const Vec3& gravity,
                                 const double* actuated, double* tau);

}  // namespace core
