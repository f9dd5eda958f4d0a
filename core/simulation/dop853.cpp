// Hairer's explicit Runge-Kutta method of order 8 with the 5th/3rd-order combined error estimate and the 7th-order
// dense output (3 extra stages, only on steps that hold output samples) ([HNW] sec. II.10; the structure follows
// scipy.integrate.DOP853).  The cheapest for smooth, non-stiff problems at tight tolerances; no stiffness test.
#include <algorithm>
#include <cmath>
#include <vector>

#include "linalg.hpp"
#include "methods.hpp"

namespace core::sim {

namespace {

// DOP853's tableau (coefficients as in scipy.integrate's dop853_coefficients): 12 stages + FSAL; rows 13-15 of A8
// are the extra stages of the 7th-order dense output
constexpr double A8[16][16] = {
    {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.05260015195876773, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.0197250569845379, 0.0591751709536137, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.02958758547680685, 0.0, 0.08876275643042054, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.2413651341592667, 0.0, -0.8845494793282861, 0.924834003261792, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.037037037037037035, 0.0, 0.0, 0.17082860872947386, 0.12546768756682242, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.037109375, 0.0, 0.0, 0.17025221101954405, 0.06021653898045596, -0.017578125, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.03709200011850479, 0.0, 0.0, 0.17038392571223998, 0.10726203044637328, -0.015319437748624402, 0.008273789163814023, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.6241109587160757, 0.0, 0.0, -3.3608926294469414, -0.868219346841726, 27.59209969944671, 20.154067550477894, -43.48988418106996, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.47766253643826434, 0.0, 0.0, -2.4881146199716677, -0.590290826836843, 21.230051448181193, 15.279233632882423, -33.28821096898486, -0.020331201708508627, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {-0.9371424300859873, 0.0, 0.0, 5.186372428844064, 1.0914373489967295, -8.149787010746927, -18.52006565999696, 22.739487099350505, 2.4936055526796523, -3.0467644718982196, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {2.273310147516538, 0.0, 0.0, -10.53449546673725, -2.0008720582248625, -17.9589318631188, 27.94888452941996, -2.8589982771350235, -8.87285693353063, 12.360567175794303, 0.6433927460157636, 0.0, 0.0, 0.0, 0.0, 0.0},
    {0.054293734116568765, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003, -5.801203960010585, 0.3111643669578199, -0.1521609496625161, 0.20136540080403034, 0.04471061572777259, 0.0, 0.0, 0.0, 0.0},
    {0.056167502283047954, 0.0, 0.0, 0.0, 0.0, 0.0, 0.25350021021662483, -0.2462390374708025, -0.12419142326381637, 0.15329179827876568, 0.00820105229563469, 0.007567897660545699, -0.008298, 0.0, 0.0, 0.0},
    {0.03183464816350214, 0.0, 0.0, 0.0, 0.0, 0.028300909672366776, 0.053541988307438566, -0.05492374857139099, 0.0, 0.0, -0.00010834732869724932, 0.0003825710908356584, -0.00034046500868740456, 0.1413124436746325, 0.0, 0.0},
    {-0.42889630158379194, 0.0, 0.0, 0.0, 0.0, -4.697621415361164, 7.683421196062599, 4.06898981839711, 0.3567271874552811, 0.0, 0.0, 0.0, -0.0013990241651590145, 2.9475147891527724, -9.15095847217987, 0.0}};
constexpr double C8[16] = {0.0, 0.05260015195876773, 0.0789002279381516, 0.1183503419072274, 0.2816496580927726, 0.3333333333333333, 0.25, 0.3076923076923077, 0.6512820512820513, 0.6, 0.8571428571428571, 1.0, 1.0, 0.1, 0.2, 0.7777777777777778};
constexpr double E3[13] = {-0.18980075407240762, 0.0, 0.0, 0.0, 0.0, 4.450312892752409, 1.8915178993145003, -5.801203960010585, -0.4226823213237919, -0.1521609496625161, 0.20136540080403034, 0.02265179219836082, 0.0};
constexpr double E5[13] = {0.01312004499419488, 0.0, 0.0, 0.0, 0.0, -1.2251564463762044, -0.4957589496572502, 1.6643771824549864, -0.35032884874997366, 0.3341791187130175, 0.08192320648511571, -0.022355307863886294, 0.0};
constexpr double D8[4][16] = {
    {-8.428938276109013, 0.0, 0.0, 0.0, 0.0, 0.5667149535193777, -3.0689499459498917, 2.38466765651207, 2.117034582445028, -0.871391583777973, 2.2404374302607883, 0.6315787787694688, -0.08899033645133331, 18.148505520854727, -9.194632392478356, -4.436036387594894},
    {10.427508642579134, 0.0, 0.0, 0.0, 0.0, 242.28349177525817, 165.20045171727028, -374.5467547226902, -22.113666853125306, 7.733432668472264, -30.674084731089398, -9.332130526430229, 15.697238121770845, -31.139403219565178, -9.35292435884448, 35.81684148639408},
    {19.985053242002433, 0.0, 0.0, 0.0, 0.0, -387.0373087493518, -189.17813819516758, 527.8081592054236, -11.57390253995963, 6.8812326946963, -1.0006050966910838, 0.7777137798053443, -2.778205752353508, -60.19669523126412, 84.32040550667716, 11.99229113618279},
    {-25.69393346270375, 0.0, 0.0, 0.0, 0.0, -154.18974869023643, -231.5293791760455, 357.6391179106141, 93.40532418362432, -37.45832313645163, 104.0996495089623, 29.8402934266605, -43.53345659001114, 96.32455395918828, -39.17726167561544, -149.72683625798564}};

class DOP853 : public AdaptiveStepper {
public:
    explicit DOP853(int n) : n_(n), K_(16 * static_cast<size_t>(n)), F_(7 * static_cast<size_t>(n)), zs_(n) {}

    // Stages 2-12 and the new point (stage 13, FSAL), the combined error estimate, the step-size control of DOP853
    // (exponent 1/8).
    bool attempt(Problem& p, double t, double h, const double* z, const double* f0, double* znew, double* fnew,
                 double* errv, const double* mag, const Options& opt, Stats& st, std::vector<Switch>&,
                 bool rejected_last, double& h_next) override {
        const int n = n_, ne = opt.ne;
        double* K = K_.data();
        std::copy(f0, f0 + n, K);
        for (int s = 1; s < 13; ++s) {
            for (int r = 0; r < n; ++r) {
                double acc = 0.0;
                for (int q = 0; q < s; ++q) acc += A8[s][q] * K[q * n + r];
                zs_[r] = z[r] + h * acc;
            }
            p.rhs(t + C8[s] * h, zs_.data(), K + s * n);
        }
        st.rhs_evals += 12;
        std::copy(zs_.begin(), zs_.end(), znew);
        double e5 = 0.0, e3 = 0.0;
        for (int r = 0; r < n; ++r) {
            double a5 = 0.0, a3 = 0.0;
            for (int q = 0; q < 13; ++q) {
                a5 += E5[q] * K[q * n + r];
                a3 += E3[q] * K[q * n + r];
            }
            errv[r] = h * a5;  // the local error estimate (for the "local" report)
            if (r < ne) {
                const double sc = opt.atol + opt.rtol * std::max(std::abs(z[r]) + mag[r], std::abs(znew[r]) + mag[r]);
                e5 += (a5 / sc) * (a5 / sc);
                e3 += (a3 / sc) * (a3 / sc);
            }
        }
        const double err = (e5 == 0.0 && e3 == 0.0) ? 0.0 : std::abs(h) * e5 / std::sqrt((e5 + 0.01 * e3) * std::max(ne, 1));
        if (!std::isfinite(err) || state_status(K + 12 * n, n, 0, 0, INFINITY) != OK) {
            h_next = h * 0.1;
            return false;
        }
        if (err > 1.0) {
            h_next = h * std::max(0.2, 0.9 * std::pow(err, -1.0 / 8.0));
            return false;
        }
        const double fac = err == 0.0 ? 10.0 : std::min(10.0, 0.9 * std::pow(err, -1.0 / 8.0));
        std::copy(K + 12 * n, K + 13 * n, fnew);
        ready_ = false;
        h_next = h * (rejected_last ? std::min(1.0, fac) : fac);
        return true;
    }

    void dense(Problem& p, double t0, double h, double x, const double* z0, const double* z1, double* out,
               Stats& st) override {
        if (!ready_) dense_coefficients(p, t0, h, z0, z1, st);
        const int n = n_;
        for (int r = 0; r < n; ++r) {
            double acc = 0.0;
            for (int k = 6; k >= 0; --k) {
                acc += F_[k * n + r];
                acc *= (6 - k) % 2 == 0 ? x : 1.0 - x;
            }
            out[r] = z0[r] + acc;
        }
    }

    int order() const override { return 8; }

private:
    // The 3 extra stages of the 7th-order interpolant, and its coefficients F (once per step).
    void dense_coefficients(Problem& p, double t0, double h, const double* z0, const double* z1, Stats& st) {
        const int n = n_;
        double *K = K_.data(), *F = F_.data();
        for (int s = 13; s < 16; ++s) {
            for (int r = 0; r < n; ++r) {
                double acc = 0.0;
                for (int q = 0; q < s; ++q) acc += A8[s][q] * K[q * n + r];
                zs_[r] = z0[r] + h * acc;
            }
            p.rhs(t0 + C8[s] * h, zs_.data(), K + s * n);
        }
        st.rhs_evals += 3;
        for (int r = 0; r < n; ++r) {
            const double dy = z1[r] - z0[r];
            F[r] = dy;
            F[n + r] = h * K[r] - dy;
            F[2 * n + r] = 2 * dy - h * (K[12 * n + r] + K[r]);
            for (int k = 0; k < 4; ++k) {
                double acc = 0.0;
                for (int q = 0; q < 16; ++q) acc += D8[k][q] * K[q * n + r];
                F[(3 + k) * n + r] = h * acc;
            }
        }
        ready_ = true;
    }

    int n_;
    std::vector<double> K_, F_, zs_;  // (16, n) stages; (7, n) the dense-output polynomial; the stage state
    bool ready_ = false;              // F holds the last accepted step's polynomial
};

}  // namespace

std::unique_ptr<AdaptiveStepper> make_dop853(int n) { return std::make_unique<DOP853>(n); }

}  // namespace core::sim
