// The linear systems (mu I - J) x = b of an implicit method on a second-order problem, reduced to the velocities
// (the way RADAU5 treats second-order systems, [HW] sec. IV.8, generalised to the robot's charts).  The state is
// z = [delta (nv), v (nv), w (quadratures)] with the Jacobian
//     J = [[Jcd, Jcv, 0], [Jad, Jav, 0], [Jwd, Jwv, 0]]
// where the chart rate of a joint's coordinates depends only on that joint's delta and v (Jcd, Jcv block-diagonal:
// zero and the identity for a 1-dof joint).  With B = mu I - Jcd and G = B^-1 Jcv, both per joint,
//     S x_v = b_v + Jad B^-1 b_d,   S = mu I - Jav - Jad G        (nv x nv, dense LU with partial pivoting)
//     x_d = B^-1 b_d + G x_v,       x_w = (b_w + Jwd x_d + Jwv x_v) / mu
// - the same solution as the whole system's, from an nv x nv factorisation instead of a (2 nv + nw) one.
#pragma once

#include <complex>
#include <vector>

namespace core::sim {

template <class T>
class ReducedSystem {
public:
    // J: the n x n row-major Jacobian (kept by the caller until the next factor); blocks: the first velocity
    // coordinate of each joint, then nv.
    void factor(const double* J, int n, const std::vector<int>& blocks, T mu);
    void solve(T* b);  // b (n) <- x

private:
    const double* J_ = nullptr;
    int n_ = 0, nv_ = 0;
    T mu_{};
    const std::vector<int>* blocks_ = nullptr;
    std::vector<T> Binv_, G_, S_, y_;  // per joint (m x m each, packed); nv x nv; scratch (n)
    std::vector<int> off_, piv_;       // the joints' offsets into Binv_ and G_; S's pivots
};

extern template class ReducedSystem<double>;
extern template class ReducedSystem<std::complex<double>>;

}  // namespace core::sim
