// Narrow phase (narrow_phase.hpp): a line-by-line port of dynamics/contact/narrow_phase.py, whose docstring has
// the table of pair functions and their methods.
//
// Every expression keeps the numba code's order of operations (the build has -ffp-contract=off, numba does not
// contract either), so that the two give the same bits: a product written s * x there is s * x here, a sum
// (a + b) - c stays (a + b) - c, and min/max/clamp pick the same operand on ties (std::min and std::max return
// their first argument on a tie, as Python's min and max do).
#include "contact/narrow_phase.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace core::contact {

namespace {

// -- small vector algebra ----------------------------------------------------------------------------------

Vec3 load3(const double* A, int64_t i) { return {A[3 * i], A[3 * i + 1], A[3 * i + 2]}; }

Mat3 load33(const double* A, int64_t i) {
    Mat3 R;
    for (int k = 0; k < 9; ++k) R[k] = A[9 * i + k];
    return R;
}

Vec3 column(const Mat3& R, int j) { return {R[j], R[3 + j], R[6 + j]}; }

double clamp(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

// x / |x|, or `fallback` when x is (nearly) zero.
Vec3 unit(const Vec3& x, const Vec3& fallback) {
    double n = std::sqrt(dot(x, x));
    return n > 1e-300 ? (1.0 / n) * x : fallback;
}

// Where the pair functions write: the buffer and the index of the pair they examine.
struct Sink {
    ContactBuffer& out;
    int64_t k;
};

// Writes contact n of the pair (midway between the surface points on a and on b); returns the new count.
int64_t emit(Sink& s, int64_t n, const Vec3& on_a, const Vec3& on_b, const Vec3& normal, double depth) {
    if (n >= s.out.capacity()) return n;  // a buffer from another scene: never write past it
    s.out.pair[n] = s.k;
    s.out.point[n] = {0.5 * (on_a.x + on_b.x), 0.5 * (on_a.y + on_b.y), 0.5 * (on_a.z + on_b.z)};
    s.out.normal[n] = normal;
    s.out.depth[n] = depth;
    return n + 1;
}

// World position of geometry g's origin (the centre of its bounding sphere).
Vec3 centre(const Scene& S, int64_t g, const Transform* oMi) {
    Vec3 p = load3(S.p, g);
    int64_t b = S.body[g];
    return b < 0 ? p : rot(oMi[b].R, p) + oMi[b].p;
}

// -- broad phase: the bounding spheres, or a's bounding sphere against plane b -----------------------------

// How far a's bounding sphere reaches into plane b's half-space, minus its radius: n . c_a - n . p_b.
double plane_height(const Scene& S, int64_t a, int64_t b, const Transform* oMi) {
    Vec3 nn = column(load33(S.R, b), 2);
    return dot(nn, centre(S, a, oMi)) - dot(nn, load3(S.p, b));
}

// False when the pair's bounding volumes are apart.
bool overlap(const Scene& S, int64_t a, int64_t b, const Transform* oMi) {
    if (S.kind[b] == PLANE) return plane_height(S, a, b, oMi) < S.radius[a];
    Vec3 d = centre(S, a, oMi) - centre(S, b, oMi);
    double r = S.radius[a] + S.radius[b];
    return dot(d, d) < r * r;
}

// -- against a plane (half-space n . x <= h); the normal is n --------------------------------------------

int64_t sphere_plane(Sink& s, int64_t n, const Vec3& c, double r, const Vec3& nn, double h) {
    double height = dot(nn, c) - h;  // the centre's height above the plane
    if (height >= r) return n;
    return emit(s, n, c - r * nn, c - height * nn, nn, r - height);
}

int64_t capsule_plane(Sink& s, int64_t n, const Vec3& c, const Vec3& u, double half, double r, const Vec3& nn,
                      double h) {
    n = sphere_plane(s, n, c - half * u, r, nn, h);
    return sphere_plane(s, n, c + half * u, r, nn, h);
}

// Each of the 8 vertices c + R (+-e0, +-e1, +-e2) below the plane.
int64_t box_plane(Sink& s, int64_t n, const Vec3& c, const Mat3& R, const Vec3& e, const Vec3& nn, double h) {
    for (int i = 0; i < 8; ++i) {
        Vec3 x = {(i & 1) ? e.x : -e.x, (i & 2) ? e.y : -e.y, (i & 4) ? e.z : -e.z};
        n = sphere_plane(s, n, c + rot(R, x), 0.0, nn, h);
    }
    return n;
}

// Each cap's deepest rim point, and on the lower cap two more at +-120 degrees (a tripod when it lies flat).
int64_t cylinder_plane(Sink& s, int64_t n, const Vec3& c, const Vec3& u, double half, double r, const Vec3& nn,
                       double h) {
    Vec3 w = dot(nn, u) * u - nn;  // -n projected on the caps' plane: towards the deepest rim point
    Vec3 t = std::fabs(u.x) < 0.9 ? Vec3{1.0, 0.0, 0.0} : Vec3{0.0, 1.0, 0.0};
    w = unit(w, unit(cross(u, t), {0.0, 0.0, 1.0}));  // a flat cylinder: any rim direction
    Vec3 v = cross(u, w);
    double lower = dot(nn, u) > 0 ? -1.0 : 1.0;  // the cap on this side of the centre is the lower one
    for (double side : {lower, -lower}) {
        Vec3 cc = c + (side * half) * u;
        n = sphere_plane(s, n, cc + r * w, 0.0, nn, h);
        if (side != lower) continue;
        for (double sn : {0.8660254037844386, -0.8660254037844386}) {
            Vec3 x = (-0.5 * r) * w + (sn * r) * v;
            n = sphere_plane(s, n, cc + x, 0.0, nn, h);
        }
    }
    return n;
}

// -- spheres and segments --------------------------------------------------------------------------------

// Two balls; `fallback`: the unit normal when their centres coincide (any direction does for two spheres, not for
// two capsules whose axes meet: there it must be across the axes).
int64_t balls(Sink& s, int64_t n, const Vec3& ca, double ra, const Vec3& cb, double rb, const Vec3& fallback) {
    Vec3 d = ca - cb;
    double dist = std::sqrt(dot(d, d));
    if (dist >= ra + rb) return n;
    Vec3 nn = dist > 1e-12 * (ra + rb) ? (1.0 / dist) * d : fallback;
    return emit(s, n, ca - ra * nn, cb + rb * nn, nn, ra + rb - dist);
}

int64_t sphere_sphere(Sink& s, int64_t n, const Vec3& ca, double ra, const Vec3& cb, double rb) {
    return balls(s, n, ca, ra, cb, rb, {0.0, 0.0, 1.0});
}

// A unit vector perpendicular to both unit axes (their common normal), or to u1 alone when they are parallel:
// the direction that separates two capsules whose axes meet.
Vec3 across(const Vec3& u1, const Vec3& u2) {
    Vec3 w = cross(u1, u2);
    if (dot(w, w) > 1e-12) return (1.0 / std::sqrt(dot(w, w))) * w;
    Vec3 a = std::fabs(u1.x) < 0.6 ? Vec3{1.0, 0.0, 0.0} : Vec3{0.0, 1.0, 0.0};
    w = a - dot(a, u1) * u1;
    return (1.0 / std::sqrt(dot(w, w))) * w;
}

// The point of the segment c + t u, |t| <= half, closest to x.
Vec3 segment_point(const Vec3& c, const Vec3& u, double half, const Vec3& x) {
    return c + clamp(dot(x - c, u), -half, half) * u;
}

// (s, t) of the closest points c1 + s u1, c2 + t u2 of two segments (unit u; Ericson 2005, sec. 5.1.9).
void segments(const Vec3& c1, const Vec3& u1, double h1, const Vec3& c2, const Vec3& u2, double h2, double& s,
              double& t) {
    Vec3 r = c1 - c2;
    double b = dot(u1, u2), c = dot(u1, r), f = dot(u2, r);
    double denom = 1.0 - b * b;
    if (denom > 1e-12)
        s = clamp((b * f - c) / denom, -h1, h1);
    else  // parallel: the point of segment 1 nearest to segment 2's centre
        s = clamp(-c, -h1, h1);
    t = b * s + f;
    if (t < -h2 || t > h2) {
        t = clamp(t, -h2, h2);
        s = clamp(b * t - c, -h1, h1);
    }
}

// Closest points of the axes; parallel axes that overlap along their length: both ends of the overlap.
int64_t capsule_capsule(Sink& sk, int64_t n, const Vec3& c1, const Vec3& u1, double h1, double r1, const Vec3& c2,
                        const Vec3& u2, double h2, double r2) {
    double b = dot(u1, u2);
    if (1.0 - b * b <= 1e-12) {
        double m = -dot(u1, c1 - c2);  // segment 2's centre along axis 1
        double lo = std::max(-h1, m - h2), hi = std::min(h1, m + h2);
        if (lo < hi) {
            for (double s : {lo, hi}) {
                Vec3 x = c1 + s * u1;
                n = balls(sk, n, x, r1, segment_point(c2, u2, h2, x), r2, across(u1, u2));
            }
            return n;
        }
    }
    double s, t;
    segments(c1, u1, h1, c2, u2, h2, s, t);
    return balls(sk, n, c1 + s * u1, r1, c2 + t * u2, r2, across(u1, u2));
}

// -- boxes (centre c, rotation R, half edges e) ------------------------------------------------------------

// Signed distance of point x to the box (negative inside).
double box_distance(const Vec3& cb, const Mat3& Rb, const Vec3& e, const Vec3& x) {
    Vec3 y = rotT(Rb, x - cb);
    Vec3 q = {std::fabs(y.x) - e.x, std::fabs(y.y) - e.y, std::fabs(y.z) - e.z};
    Vec3 o = {std::max(q.x, 0.0), std::max(q.y, 0.0), std::max(q.z, 0.0)};
    return std::sqrt(dot(o, o)) + std::min(std::max(q.x, std::max(q.y, q.z)), 0.0);
}

// Sphere (c, r) against the box: the box's closest point, or from inside the nearest face.
int64_t sphere_box(Sink& s, int64_t n, const Vec3& c, double r, const Vec3& cb, const Mat3& Rb, const Vec3& e) {
    Vec3 y = rotT(Rb, c - cb);
    Vec3 z = {clamp(y.x, -e.x, e.x), clamp(y.y, -e.y, e.y), clamp(y.z, -e.z, e.z)};
    Vec3 d = y - z;
    double dist = std::sqrt(dot(d, d));
    if (dist > 0.0) {  // centre outside the box
        if (dist >= r) return n;
        Vec3 nn = rot(Rb, (1.0 / dist) * d);
        return emit(s, n, c - r * nn, cb + rot(Rb, z), nn, r - dist);
    }
    int i = 0;  // inside: leave through the nearest face
    double gap = e[0] - std::fabs(y[0]);
    for (int j = 1; j < 3; ++j)
        if (e[j] - std::fabs(y[j]) < gap) i = j, gap = e[j] - std::fabs(y[j]);
    double sgn = y[i] >= 0.0 ? 1.0 : -1.0;
    Vec3 nn = sgn * column(Rb, i);
    return emit(s, n, c - r * nn, c + gap * nn, nn, r + gap);
}

// The segment c + x u's deepest point in the box, x in [-half, half], by golden-section search (the box's signed
// distance along a line is convex); GOLDEN_STEPS steps shrink the interval to round-off (0.618^60).
double deepest_along(const Vec3& c, const Vec3& u, double half, const Vec3& cb, const Mat3& Rb, const Vec3& e) {
    constexpr int GOLDEN_STEPS = 60;
    const double g = 0.6180339887498949;
    double lo = -half, hi = half;
    double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
    double f1 = box_distance(cb, Rb, e, c + x1 * u);
    double f2 = box_distance(cb, Rb, e, c + x2 * u);
    for (int step = 0; step < GOLDEN_STEPS; ++step) {
        if (f1 <= f2) {
            hi = x2, x2 = x1, f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = box_distance(cb, Rb, e, c + x1 * u);
        } else {
            lo = x1, x1 = x2, f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = box_distance(cb, Rb, e, c + x2 * u);
        }
    }
    return 0.5 * (lo + hi);
}

// Both end spheres when both penetrate (a capsule lying on a face), else the segment's deepest point.
int64_t capsule_box(Sink& s, int64_t n, const Vec3& c, const Vec3& u, double half, double r, const Vec3& cb,
                    const Mat3& Rb, const Vec3& e) {
    Vec3 p0 = c - half * u, p1 = c + half * u;
    if (box_distance(cb, Rb, e, p0) < r && box_distance(cb, Rb, e, p1) < r) {
        n = sphere_box(s, n, p0, r, cb, Rb, e);
        return sphere_box(s, n, p1, r, cb, Rb, e);
    }
    return sphere_box(s, n, c + deepest_along(c, u, half, cb, Rb, e) * u, r, cb, Rb, e);
}

// Overlap of the two boxes' projections on the unit axis L (negative: L separates them); d = c_a - c_b.
double box_overlap(const Vec3& L, const Vec3& d, const Mat3& RA, const Vec3& ea, const Mat3& RB, const Vec3& eb) {
    double ra = ea.x * std::fabs(dot(column(RA, 0), L)) + ea.y * std::fabs(dot(column(RA, 1), L)) +
                ea.z * std::fabs(dot(column(RA, 2), L));
    double rb = eb.x * std::fabs(dot(column(RB, 0), L)) + eb.y * std::fabs(dot(column(RB, 1), L)) +
                eb.z * std::fabs(dot(column(RB, 2), L));
    return ra + rb - std::fabs(dot(d, L));
}

// A box of the box-box test: centre, rotation, half edges.
struct Box {
    Vec3 c;
    Mat3 R;
    Vec3 e;
};

// The clipped polygon of box-box: two buffers of up to 8 points, the clip reading one and writing the other.
using Polygon = Vec3[2][8];

// Clip the polygon work[src][:m] by the half-space t . x <= h into work[1 - src]; returns its size (one more at
// most, and never past 8).  After an even number of clips the polygon is back in work[0].
int clip(Polygon& work, int src, int m, const Vec3& t, double h) {
    int dst = 1 - src, out = 0;
    for (int v = 0; v < m; ++v) {
        Vec3 P = work[src][v > 0 ? v - 1 : m - 1], Q = work[src][v];
        double fp = dot(t, P) - h, fq = dot(t, Q) - h;
        if ((fp <= 0.0) != (fq <= 0.0) && out < 8)  // the edge crosses the plane
            work[dst][out++] = P + (fp / (fp - fq)) * (Q - P);
        if (fq <= 0.0 && out < 8) work[dst][out++] = Q;
    }
    return out;
}

// work[0][:4] = the incident box's face most opposed to the reference normal N (its corners in order).
void incident_face(const Box& inc, const Vec3& N, Polygon& work) {
    int j = 0;
    double big = -1.0;  // the incident face: its normal most anti-parallel to N
    for (int m = 0; m < 3; ++m)
        if (std::fabs(dot(column(inc.R, m), N)) > big) j = m, big = std::fabs(dot(column(inc.R, m), N));
    Vec3 nj = column(inc.R, j);
    Vec3 ic = inc.c + (dot(nj, N) > 0.0 ? -inc.e[j] : inc.e[j]) * nj;
    Vec3 s1 = inc.e[(j + 1) % 3] * column(inc.R, (j + 1) % 3), s2 = inc.e[(j + 2) % 3] * column(inc.R, (j + 2) % 3);
    for (int v = 0; v < 4; ++v)
        work[0][v] = ic + ((v == 0 || v == 3 ? 1.0 : -1.0) * s1 + (v < 2 ? 1.0 : -1.0) * s2);
}

// Reference face i of box ref (outward normal N, towards the other box): the incident box's face most opposed to
// N clipped by the reference face's four side planes (Sutherland-Hodgman); each clipped point below the reference
// face is a contact.
int64_t box_face(Sink& s, int64_t n, const Box& ref, int i, const Vec3& N, const Box& inc, bool ref_is_a) {
    Polygon work;
    incident_face(inc, N, work);
    int m = 4;
    for (int side = 0; side < 4; ++side) {  // the planes t . (x - c) <= e along the face's two tangents, both ways
        int ax = (i + 1 + side / 2) % 3;
        Vec3 t = (side % 2 == 0 ? 1.0 : -1.0) * column(ref.R, ax);
        m = clip(work, side % 2, m, t, dot(t, ref.c) + ref.e[ax]);
    }
    Vec3 fc = ref.c + ref.e[i] * N;
    for (int v = 0; v < m; ++v) {
        const Vec3& x = work[0][v];
        double sep = dot(x - fc, N);
        if (sep >= 0.0) continue;
        Vec3 on_ref = x - sep * N;
        n = ref_is_a ? emit(s, n, on_ref, x, -1.0 * N, -sep) : emit(s, n, x, on_ref, N, -sep);
    }
    return n;
}

// Edge i of A against edge j of B along the axis L (from B towards A): the edges that support each box towards
// the other, and their closest points.
int64_t box_edges(Sink& s, int64_t n, const Box& A, int i, const Box& B, int j, const Vec3& L) {
    Vec3 pa = A.c, pb = B.c;
    for (int m = 0; m < 3; ++m) {
        if (m != i) {
            Vec3 a = column(A.R, m);
            pa = pa + (dot(a, L) > 0.0 ? -A.e[m] : A.e[m]) * a;
        }
        if (m != j) {
            Vec3 b = column(B.R, m);
            pb = pb + (dot(b, L) > 0.0 ? B.e[m] : -B.e[m]) * b;
        }
    }
    Vec3 ua = column(A.R, i), ub = column(B.R, j);
    double sa, tb;
    segments(pa, ua, A.e[i], pb, ub, B.e[j], sa, tb);
    Vec3 qa = pa + sa * ua, qb = pb + tb * ub;
    double depth = dot(qb - qa, L);
    if (depth <= 0.0) return n;
    return emit(s, n, qa, qb, L, depth);
}

// The separating-axis test's verdict: the axis of least overlap and its code (0-2 a face of A, 3-5 of B, 6 + 3 i +
// j the edges i of A and j of B), or separated.
struct Axis {
    bool separated = false;
    Vec3 L = {0.0, 0.0, 1.0};
    int code = -1;
};

// The 6 face normals, then the 9 edge crossings; an edge axis is taken only when its overlap is below EDGE_BIAS of
// the best face axis's (faces give a manifold; edges, nearly parallel to a face, a single point).
Axis least_overlap(const Box& A, const Box& B, const Vec3& d) {
    constexpr double EDGE_BIAS = 0.95;
    Axis ax;
    double best = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 6; ++i) {
        Vec3 L = i < 3 ? column(A.R, i) : column(B.R, i - 3);
        double o = box_overlap(L, d, A.R, A.e, B.R, B.e);
        if (o < 0.0) return {true};
        if (o < best) best = o, ax.L = L, ax.code = i;
    }
    const double face = best;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            Vec3 L = cross(column(A.R, i), column(B.R, j));
            double ln = std::sqrt(dot(L, L));
            if (ln < 1e-6) continue;  // (nearly) parallel edges: a face axis covers them
            L = (1.0 / ln) * L;
            double o = box_overlap(L, d, A.R, A.e, B.R, B.e);
            if (o < 0.0) return {true};
            if (o < EDGE_BIAS * face && o < best) best = o, ax.L = L, ax.code = 6 + 3 * i + j;
        }
    return ax;
}

// Separating axis test over 15 axes; the axis of least overlap gives a face manifold or one edge-edge point.
int64_t box_box(Sink& s, int64_t n, const Box& A, const Box& B) {
    Vec3 d = A.c - B.c;
    Axis ax = least_overlap(A, B, d);
    // code -1 (every overlap NaN: a non-finite pose) has no axis; numba would index a column -1, we write nothing
    if (ax.separated || ax.code < 0) return n;
    Vec3 L = dot(d, ax.L) < 0.0 ? -1.0 * ax.L : ax.L;  // from b towards a
    if (ax.code < 3) return box_face(s, n, A, ax.code, -1.0 * L, B, true);  // A's face: outward normal -L
    if (ax.code < 6) return box_face(s, n, B, ax.code - 3, L, A, false);
    return box_edges(s, n, A, (ax.code - 6) / 3, B, (ax.code - 6) % 3, L);
}

// -- the table ------------------------------------------------------------------------------------------------

// A geometry at its world pose: kind, rotation, centre, size.
struct Placed {
    int64_t kind;
    Mat3 R;
    Vec3 c, size;
    Vec3 axis() const { return column(R, 2); }
};

Placed placed(const Scene& S, int64_t g, const Transform* oMi) {
    Transform X = geometry_pose(S, g, oMi);
    return {S.kind[g], X.R, X.p, load3(S.size, g)};
}

// a (sphere, point, capsule, cylinder or box) against plane b.
int64_t against_plane(Sink& s, int64_t n, const Placed& a, const Placed& b) {
    Vec3 nn = b.axis();
    double h = dot(nn, b.c);
    if (a.kind <= POINT) return sphere_plane(s, n, a.c, a.size[0], nn, h);
    if (a.kind == CAPSULE) return capsule_plane(s, n, a.c, a.axis(), 0.5 * a.size[1], a.size[0], nn, h);
    if (a.kind == CYLINDER) return cylinder_plane(s, n, a.c, a.axis(), 0.5 * a.size[1], a.size[0], nn, h);
    return box_plane(s, n, a.c, a.R, 0.5 * a.size, nn, h);
}

// a (sphere, point, capsule, cylinder as a capsule, or box) against box b.
int64_t against_box(Sink& s, int64_t n, const Placed& a, const Placed& b) {
    Vec3 eb = 0.5 * b.size;
    if (a.kind <= POINT) return sphere_box(s, n, a.c, a.size[0], b.c, b.R, eb);
    if (a.kind <= CYLINDER) return capsule_box(s, n, a.c, a.axis(), 0.5 * a.size[1], a.size[0], b.c, b.R, eb);
    return box_box(s, n, {a.c, a.R, 0.5 * a.size}, {b.c, b.R, eb});
}

// The contacts of pair k = (a, b) (kind[a] <= kind[b]), written from out[n]; returns the new count.
int64_t pair_contacts(const Scene& S, int64_t k, int64_t ga, int64_t gb, const Transform* oMi, ContactBuffer& out,
                      int64_t n) {
    Sink s{out, k};
    const Placed a = placed(S, ga, oMi), b = placed(S, gb, oMi);
    if (b.kind == PLANE) return against_plane(s, n, a, b);
    if (b.kind == BOX) return against_box(s, n, a, b);
    if (b.kind >= CAPSULE) {  // a capsule or a cylinder (as a capsule)
        Vec3 ub = b.axis();
        if (a.kind <= POINT)
            return sphere_sphere(s, n, a.c, a.size[0], segment_point(b.c, ub, 0.5 * b.size[1], a.c), b.size[0]);
        return capsule_capsule(s, n, a.c, a.axis(), 0.5 * a.size[1], a.size[0], b.c, ub, 0.5 * b.size[1],
                               b.size[0]);
    }
    return sphere_sphere(s, n, a.c, a.size[0], b.c, b.size[0]);
}

}  // namespace

Transform geometry_pose(const Scene& S, int64_t g, const Transform* oMi) {
    Transform X = {load33(S.R, g), load3(S.p, g)};
    int64_t b = S.body[g];
    return b < 0 ? X : compose(oMi[b], X);
}

double separation(const Scene& S, int64_t a, int64_t b, const Transform* oMi) {
    if (S.kind[b] == PLANE) return plane_height(S, a, b, oMi) - S.radius[a];
    Vec3 d = centre(S, a, oMi) - centre(S, b, oMi);
    return std::sqrt(dot(d, d)) - (S.radius[a] + S.radius[b]);
}

int64_t collide(const Scene& S, const Transform* oMi, ContactBuffer& out) {
    int64_t n = 0;
    for (int64_t k = 0; k < S.npairs; ++k) {
        int64_t a = S.pair_a[k], b = S.pair_b[k];
        if (overlap(S, a, b, oMi)) n = pair_contacts(S, k, a, b, oMi, out, n);
    }
    return n;
}

}  // namespace core::contact
