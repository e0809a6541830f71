// Adding-doubling for a layer stack (see adding_doubling.h for the scope and references).
//
// 1. Discrete directions. Snell's invariant s = n sin(theta) is kept by every smooth interface,
//    so with u = s^2 a direction of invariant u exists in a medium of index n iff u < n^2, where
//    its cosine is mu = sqrt(1 - u/n^2). The projected solid angle is 2 mu dmu = du / n^2 (per
//    2 pi of azimuth), the same measure in u for every medium up to 1/n^2: this is the invariance
//    of etendue, n^2 cos dw, behind the n^2 law of radiance (Veach's thesis, 5.2). The u axis is
//    cut at the squared indices of the media, n_1^2 < n_2^2 < ...; segment [a, b] is parametrised
//    by the cosine in its top medium, t = sqrt(1 - u/b), so that du = 2 b t dt and Gauss-Legendre
//    nodes t_i, weights w_i on [0, sqrt(1 - a/b)] give
//        int f du  ~  sum_i f(u_i) 2 b t_i w_i.
//    In the top medium of the segment t is the cosine itself (the radiance is smooth in mu, not
//    in u, near grazing), and in any higher medium mu = sqrt(n^2 - b + b t^2)/n is smooth in t.
//    A medium of index n sees every node with u < n^2 (all segments up to n^2, the critical
//    angles on segment ends as in Prahl's split Gauss/Radau quadrature) with the weight
//        W_j = 2 b t_j w_j / n^2,   sum_j W_j = int_0^{n^2} du/n^2 = 1 exactly.
//
// 2. Flux form. Every operator acts on F_j, the power per unit area carried by node j (for
//    azimuthally uniform radiance L_j, F_j = pi L_j W_j). Reflection and transmission are
//    matrices M_ij = fraction of the power arriving in node j that leaves in node i; their
//    column sums are the node's total reflectance/transmittance. An interface is diagonal: the
//    power of node j goes to node j on the other side with the Fresnel factor 1 - F (radiance
//    then scales by n^2 by itself, since W scales by 1/n^2), and is reflected with F; a node that
//    cannot exist on the far side (u >= n_far^2) is totally reflected. A collimated beam of unit
//    power at cosine mu_0 is one more node with W = 0: nothing scatters into it (its rows carry
//    only the unscattered beam), and its column is the response to the beam.
//
// 3. The layer's equation. In a layer of single-scattering albedo a and azimuthally averaged
//    phase function p0(mu, mu') (normalised: int p0 2 pi dmu' over [-1, 1] = 1), the m = 0
//    radiative transfer equation for downward (+) and upward (-) radiance at optical depth tau,
//        +-mu dL(+-mu)/dtau = -L + a int p0(+-mu, mu') L(mu') 2 pi dmu'
//    (Chandrasekhar 1960, ch. 1; Prahl 1995, eq. 5.7), discretised with the nodes' weights
//    2 pi (W_j / 2 mu_j) and written for the fluxes F_j = pi L_j W_j, is
//        dF+/dtau = -alpha F+ + beta F-,      -dF-/dtau = -alpha F- + beta F+,
//        alpha_ij = delta_ij / mu_i - a K_ij(+),   beta_ij = a K_ij(-),
//        K_ij(+-) = pi W_i p0(mu_i, +-mu_j) / (mu_i mu_j)
//    (the beam of node j crosses dtau / mu_j of path; the in-scattered radiance at mu_i becomes
//    flux with pi W_i and travels dtau / mu_i). Energy conservation of one scattering needs
//    sum_i mu_j (K_ij(+) + K_ij(-)) = 1 for every column j; the quadrature does not give this
//    exactly for a truncated Legendre series on our nodes, so each column of p0 is divided by its
//    discrete integral (Wiscombe 1976's renormalisation of the phase function; the correction is
//    of the order of the quadrature error).
//
// 4. Phase function and delta-M. The HG lobes' Legendre moments are g^l, the layer's chi_l =
//    sum_i sigma_s,i g_i^l / sigma_s (the scattering-weighted mixture of stack.h). p0 is the
//    addition theorem's m = 0 term, p0(mu, mu') = (1/4 pi) sum_{l<M} (2l+1) chi'_l P_l(mu) P_l(mu').
//    Delta-M (Wiscombe 1977) keeps M terms exactly and puts the rest in a forward delta of
//    weight f = chi_M: chi'_l = (chi_l - f)/(1 - f), tau' = (1 - a f) tau,
//    a' = a (1 - f)/(1 - a f) (f from the lobes with g > 0 only: a backward lobe has no forward
//    peak to truncate). The forward delta is unscattered light for the solver, so the
//    totals R and T are right but their split into unscattered and scattered is not: the exact
//    unscattered parts come from materials/analytic/zeroth_order and the scattered parts are the rest.
//    M is the number of the medium's nodes per hemisphere, as in iad (Prahl 1995, 5.3.3).
//
// 5. Starting layer. The diamond initialisation (Wiscombe 1976; iad's default) integrates the
//    system of 3. over a thin layer Delta by the trapezoid rule: with h = Delta/2,
//        (I + h alpha) F+(Delta) - h beta F-(0)     = (I - h alpha) F+(0) + h beta F-(Delta),
//        -h beta F+(Delta) + (I + h alpha) F-(0)    = h beta F+(0) + (I - h alpha) F-(Delta).
//    The sum and difference of the two decouple: with S = I + h alpha, D = h beta, P = I - h alpha,
//        A+ = (S - D)^-1 (P + D),  A- = (S + D)^-1 (P - D),
//        T = (A+ + A-)/2,  R = (A+ - A-)/2
//    (F+(Delta) = T F+(0) + R F-(Delta); a homogeneous layer is the same seen from either side).
//    Delta is the layer's (scaled) optical depth halved until it is at most the smallest cosine
//    of the medium's nodes (Wiscombe's criterion as iad applies it; error O(Delta^2) overall).
//
// 6. Doubling and adding (van de Hulst 1980, ch. 4; Prahl 1995, eqs. 5.36-5.39). Element A over
//    element B, with R_t / R_b reflection for light from above / below and T_d / T_u the
//    downward / upward transmission, in flux form (ordinary matrix products):
//        T_d(AB) = T_d(B) (I - R_b(A) R_t(B))^-1 T_d(A)
//        R_t(AB) = R_t(A) + T_u(A) (I - R_t(B) R_b(A))^-1 R_t(B) T_d(A)
//    (the geometric series of the bounces between A and B). The stack is added from the bottom
//    up, so only R_t and T_d of the part below are needed. Doubling is A over A for a
//    homogeneous layer: R2 = R + T R (I - R R)^-1 T, T2 = T (I - R R)^-1 T. A semi-infinite layer
//    is doubled until R stops changing (1e-13) or its scaled optical depth reaches 1e8 (1e6 and
//    the exact column sums 1 without absorption; see layer_element). A finite layer whose optical
//    depth overflows a double is that semi-infinite layer with T = 0 (exp(-tau) underflows long
//    before tau overflows), so no loop depends on an infinite depth.
//
// 7. Lambert substrate: no interface (as in the walk); the power reaching it is reflected with
//    the albedo into the nodes of the last layer's medium in proportion to W_i (Lambert's law
//    puts power in proportion to projected solid angle): R_t,ij = albedo W_i, T = 0.
//
// 8. Azimuthal modes (for the BRDF/BTDF). By the addition theorem of spherical harmonics the
//    phase function is p(mu, mu', dphi) = sum_m (2 - delta_m0) p_m(mu, mu') cos(m dphi) with
//        p_m(mu, mu') = (1/4 pi) sum_{l>=m} (2l+1) chi'_l Pt_l^m(mu) Pt_l^m(mu')
//    (Pt the normalised associated Legendre functions; Chandrasekhar 1960, ch. 6; Wiscombe 1977;
//    Zeltner and Jakob 2018 use the same expansion). With the radiance written as
//    L = sum_m L_m(mu) cos(m dphi), the in-scattering of mode m is 2 pi int p_m L_m dmu', so every
//    mode obeys the equation of 3. with p_0 replaced by p_m (no renormalisation for m >= 1) and is
//    solved by the same doubling and adding; interfaces are the same for every mode (Fresnel
//    does not depend on azimuth) and a Lambert surface reflects only mode 0. A collimated beam is
//    delta(phi) = (1/2 pi)(1 + 2 sum_m cos(m phi)), so its mode m is (2 - delta_m0) times its
//    mode 0, and the radiance leaving in direction (mu_i, phi) per unit incident power is
//        f(mu_i, phi) = sum_{m < M} (2 - delta_m0) cos(m (phi - pi)) F_m,i / (pi W_i)
//    (phi from the light's azimuth as in brdf_table.h; the beam travels towards phi = pi), where
//    F_m,i is the incidence column of the mode-m R_t (or T_d) at the outside node i. Modes
//    m >= M (the delta-M order) have no scattering and add nothing to the bins. The bins average
//    f over |cos| and phi weighted by projected solid angle: the phi integral of cos is exact,
//    the cosine integral uses Gauss-Legendre in mu^2 on a Lagrange interpolant of the node
//    values within each segment.
// 9. The delta-M forward peak is unscattered for the solver, so the scattered power it carries
//    leaves in the mirror or ballistic direction; it is the difference between the exact
//    diffuse total and the bins' power, and goes into the bin that holds that direction.
// 10. A rough top (interface_fourier.h: its BSDF projected per mode onto these nodes, outgoing
//    power gathered over each node's cell and incoming power spread over it; Jakob et al. 2014)
//    is a full, non-diagonal element. It spreads the incident beam over the real nodes at once,
//    so nothing stays in the incidence node and no forward peak is left over (9.). Its own
//    reflection of the beam, Rt of the top, is kept apart (Element::Rt_direct): it is the glossy
//    lobe, R_specular of the totals as the walk reports it, and not in the bins, which hold the
//    light that entered the stack. The cells: each segment's Gauss nodes t_i take, in order of
//    t, consecutive intervals of s = t^2 as long as their weights 2 t_i w_i (which sum to
//    t_max^2), so a cell's measure is its node's weight exactly.
// 13. A diffuse interface (materials/interfaces/diffuse_interface.h: PROSPECT's plate surface,
//    docs/adding_doubling.md, "Diffuse interfaces") is a full element as a rough one is, built on
//    the nodes (diffuse_interface_element): specular reflection on its light side, Lambertian
//    transmission into the dense side, and from the dense side a constant transmission t_hi and a
//    Lambertian reflection 1 - t_hi. Its diffuse parts have no azimuthal modes above 0. The
//    light that crossed one is spread, so, as with energy-conserving rough interfaces (11.), the
//    totals split by the unscattered solution.
#include "materials/adding_doubling/adding_doubling.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <tbb/parallel_for.h>

#include "materials/adding_doubling/adding_doubling_test_hooks.h"
#include "materials/adding_doubling/interface_fourier.h"
#include "materials/analytic/first_order.h"  // GaussLegendreRule
#include "materials/interfaces/fresnel.h"
#include "materials/base/sampling.h"  // kPi
#include "materials/analytic/zeroth_order.h"

namespace lamina {

namespace adding_doubling_test_hooks {
bool double_on_every_node = false;
}  // namespace adding_doubling_test_hooks

namespace {


// Dense square matrix, row-major.
// An allocator that leaves new doubles uninitialised unless a value is given: a product's
// storage is written whole by the product, so zeroing it first (a memset, 7% of the solver's
// time) is wasted.
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  using std::allocator<T>::allocator;
  template <class U>
  void construct(U* p) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

struct Matrix {
  int n = 0;
  std::vector<double, DefaultInitAllocator<double>> a;
  Matrix() = default;
  explicit Matrix(int size) : n(size), a(static_cast<std::size_t>(size) * size, 0.0) {}
  struct Uninitialised {};
  Matrix(int size, Uninitialised) : n(size), a(static_cast<std::size_t>(size) * size) {}
  double& operator()(int i, int j) { return a[static_cast<std::size_t>(i) * n + j]; }
  double operator()(int i, int j) const { return a[static_cast<std::size_t>(i) * n + j]; }
  static Matrix identity(int size) {
    Matrix m(size);
    for (int i = 0; i < size; ++i) m(i, i) = 1.0;
    return m;
  }
};

// The products and solves below dominate the solver's time (callgrind on skin_oily at 16 points:
// ~75% in them), on matrices of 15-80 nodes. They work on tiles of 4 rows x 4 columns held in
// registers (GCC/Clang vector extensions, 4 doubles; two SSE2 registers each, or one AVX2
// register in the clone for CPUs that have it), so each element of the right factor is loaded
// once per 4 rows instead of once per row, and the result is not stored between terms. Every
// element is still the sum over k in ascending order, term by term as the plain triple loop
// adds it and without fused multiply-adds (neither clone enables FMA), so the results are the
// same bits as the plain loops' on any CPU.
typedef double Double4 __attribute__((vector_size(32)));
// Passing a 32-byte vector by value changes the ABI between AVX and non-AVX code (-Wpsabi); these
// helpers are internal and inlined into each clone, so no call crosses that boundary.
#pragma GCC diagnostic ignored "-Wpsabi"

inline Double4 load4(const double* p) {
  Double4 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void store4(double* p, Double4 v) { std::memcpy(p, &v, sizeof v); }

// z = x y (n x n, row-major; z's old contents are overwritten). Rows of x that are zero over a whole tile
// are skipped (diagonal and embedded matrices: interfaces, media that see some nodes only).
__attribute__((target_clones("avx2", "default"))) void multiply_into(int n, const double* x, const double* y, double* z) {
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    const double* x0 = x + static_cast<std::size_t>(i) * n;
    const double *x1 = x0 + n, *x2 = x1 + n, *x3 = x2 + n;
    int j = 0;
    for (; j + 4 <= n; j += 4) {
      Double4 a0 = {0, 0, 0, 0}, a1 = a0, a2 = a0, a3 = a0;
      for (int k = 0; k < n; ++k) {
        if (x0[k] == 0.0 && x1[k] == 0.0 && x2[k] == 0.0 && x3[k] == 0.0) continue;
        const Double4 yk = load4(y + static_cast<std::size_t>(k) * n + j);
        a0 += x0[k] * yk;
        a1 += x1[k] * yk;
        a2 += x2[k] * yk;
        a3 += x3[k] * yk;
      }
      double* zi = z + static_cast<std::size_t>(i) * n + j;
      store4(zi, a0);
      store4(zi + n, a1);
      store4(zi + 2 * n, a2);
      store4(zi + 3 * n, a3);
    }
    for (; j < n; ++j)
      for (int r = 0; r < 4; ++r) {
        const double* xr = x0 + static_cast<std::size_t>(r) * n;
        double sum = 0.0;
        for (int k = 0; k < n; ++k)
          if (xr[k] != 0.0) sum += xr[k] * y[static_cast<std::size_t>(k) * n + j];
        z[static_cast<std::size_t>(i + r) * n + j] = sum;
      }
  }
  for (; i < n; ++i) {
    const double* xi = x + static_cast<std::size_t>(i) * n;
    double* zi = z + static_cast<std::size_t>(i) * n;
    for (int j = 0; j < n; ++j) zi[j] = 0.0;
    for (int k = 0; k < n; ++k) {
      if (xi[k] == 0.0) continue;
      const double* yk = y + static_cast<std::size_t>(k) * n;
      for (int j = 0; j < n; ++j) zi[j] += xi[k] * yk[j];
    }
  }
}

Matrix operator*(const Matrix& x, const Matrix& y) {
  Matrix z(x.n, Matrix::Uninitialised{});
  multiply_into(x.n, x.a.data(), y.a.data(), z.a.data());
  return z;
}
Matrix operator+(Matrix x, const Matrix& y) {
  for (std::size_t i = 0; i < x.a.size(); ++i) x.a[i] += y.a[i];
  return x;
}
Matrix operator-(Matrix x, const Matrix& y) {
  for (std::size_t i = 0; i < x.a.size(); ++i) x.a[i] -= y.a[i];
  return x;
}
Matrix scaled(Matrix x, double s) {
  for (double& v : x.a) v *= s;
  return x;
}

void factorise(int n, double* lu, int* piv);
void substitute(int n, const double* lu, double* b);

// LU factorisation with partial pivoting (Golub and Van Loan, algorithm 3.4.1) and solves with
// matrix right-hand sides. A zero pivot can only come from a direction trapped between two
// totally reflecting interfaces in a layer that neither scatters nor absorbs (I - R R has a zero
// row there); no light can enter such a direction, its right-hand side is zero, and the pivot is
// taken as 1 so that its solution is 0.
struct LU {
  Matrix lu;
  std::vector<int> piv;
  explicit LU(Matrix m) : lu(std::move(m)), piv(lu.n) { factorise(lu.n, lu.a.data(), piv.data()); }
  // X = A^-1 B.
  Matrix solve(Matrix b) const {
    const int n = lu.n;
    for (int k = 0; k < n; ++k)
      if (piv[k] != k)
        for (int j = 0; j < n; ++j) std::swap(b(k, j), b(piv[k], j));
    substitute(n, lu.a.data(), b.a.data());
    return b;
  }
};

// Forward substitution with the unit lower triangle of `lu`, then back substitution with its
// upper triangle, for n right-hand sides in the rows of b (n x n, row-major, in place): row i
// of b loses l_ik b_k for k = 0..i-1 in that order, then u_ik b_k for k = i+1..n-1, and is
// divided by u_ii (multiplied by its inverse, as the plain loops did). The 4-column tiles keep
// the row in registers over k; the order of the terms is that of the plain loops.
// Row i of the right-hand sides b (n x n, row-major) loses c_k b_k for k = k0..k1-1 in that
// order, then is multiplied by `scale` (1 for the forward substitution, exact). Four 4-column
// tiles at a time: four independent chains of subtractions, where one chain would wait for each
// subtraction's latency. Inlined into each clone of substitute.
[[gnu::always_inline]] inline void eliminate_row(int n, const double* c, int k0, int k1, double* b, int i, double scale) {
  auto row = [&](int r) { return b + static_cast<std::size_t>(r) * n; };
  double* bi = row(i);
  int j = 0;
  for (; j + 16 <= n; j += 16) {
    Double4 a0 = load4(bi + j), a1 = load4(bi + j + 4), a2 = load4(bi + j + 8), a3 = load4(bi + j + 12);
    for (int k = k0; k < k1; ++k) {
      if (c[k] == 0.0) continue;
      const double* bk = row(k) + j;
      a0 -= c[k] * load4(bk);
      a1 -= c[k] * load4(bk + 4);
      a2 -= c[k] * load4(bk + 8);
      a3 -= c[k] * load4(bk + 12);
    }
    store4(bi + j, a0 * scale);
    store4(bi + j + 4, a1 * scale);
    store4(bi + j + 8, a2 * scale);
    store4(bi + j + 12, a3 * scale);
  }
  for (; j + 4 <= n; j += 4) {
    Double4 acc = load4(bi + j);
    for (int k = k0; k < k1; ++k)
      if (c[k] != 0.0) acc -= c[k] * load4(row(k) + j);
    store4(bi + j, acc * scale);
  }
  for (; j < n; ++j) {
    for (int k = k0; k < k1; ++k)
      if (c[k] != 0.0) bi[j] -= c[k] * row(k)[j];
    bi[j] *= scale;
  }
}

__attribute__((target_clones("avx2", "default"))) void substitute(int n, const double* lu, double* b) {
  for (int i = 0; i < n; ++i) eliminate_row(n, lu + static_cast<std::size_t>(i) * n, 0, i, b, i, 1.0);
  for (int i = n - 1; i >= 0; --i) {
    const double* ui = lu + static_cast<std::size_t>(i) * n;
    eliminate_row(n, ui, i + 1, n, b, i, 1.0 / ui[i]);
  }
}

// LU factorisation with partial pivoting in place (Golub and Van Loan, algorithm 3.4.1; see LU),
// row-major n x n; piv[k] the row swapped with row k at step k.
__attribute__((target_clones("avx2", "default"))) void factorise(int n, double* lu, int* piv) {
  auto at = [&](int i, int j) -> double& { return lu[static_cast<std::size_t>(i) * n + j]; };
  for (int k = 0; k < n; ++k) {
    int p = k;
    for (int i = k + 1; i < n; ++i)
      if (std::abs(at(i, k)) > std::abs(at(p, k))) p = i;
    piv[k] = p;
    if (p != k)
      for (int j = 0; j < n; ++j) std::swap(at(k, j), at(p, j));
    if (at(k, k) == 0.0) at(k, k) = 1.0;
    const double inv = 1.0 / at(k, k);
    const double* uk = &at(k, 0);
    for (int i = k + 1; i < n; ++i) {
      const double l = at(i, k) *= inv;
      if (l == 0.0) continue;
      double* ri = &at(i, 0);
      for (int j = k + 1; j < n; ++j) ri[j] -= l * uk[j];
    }
  }
}

// The nodes of 1.: node j has invariant u_j = b_j (1 - t_j^2) and du-weight dw_j = 2 b_j t_j w_j
// (0 for the incidence nodes, which have b = n_above^2 and t = mu_0 and come after the real ones).
struct Nodes {
  std::vector<double> b, t, du_weight;
  // The node's cell in u, [u_lo, u_hi], of length du_weight (u_lo = u_hi for an incidence node):
  // within its segment, cells of s = t^2 (du = b ds) laid end to end in the order of t, each as
  // long as the node's weight 2 t_i w_i (they sum to t_max^2 exactly). Where a rough interface
  // gathers outgoing power (interface_fourier.h).
  std::vector<double> u_lo, u_hi;
  std::vector<int> incidences;
  int real = 0;  // nodes with weight > 0
  int size() const { return static_cast<int>(b.size()); }
};

Nodes make_nodes(const std::vector<double>& indices, double n_above, const std::vector<double>& mu0s, int order) {
  std::vector<double> sq;
  for (double n : indices) sq.push_back(n * n);
  std::sort(sq.begin(), sq.end());
  sq.erase(std::unique(sq.begin(), sq.end()), sq.end());
  Nodes nodes;
  double a = 0.0;
  for (double b : sq) {
    const double t_max = std::sqrt(1.0 - a / b);
    const int count = a == 0.0 ? order : std::max(2, static_cast<int>(std::ceil(order * t_max)));
    std::vector<double> x(count), w(count);
    gauss_legendre(count, 0.0, t_max, x.data(), w.data());
    std::vector<int> order_by_t(count);
    for (int i = 0; i < count; ++i) order_by_t[i] = i;
    std::sort(order_by_t.begin(), order_by_t.end(), [&](int i, int k) { return x[i] < x[k]; });
    std::vector<double> s_lo(count), s_hi(count);
    double s_end = 0.0;
    for (int i : order_by_t) {
      s_lo[i] = s_end;
      s_end += 2.0 * x[i] * w[i];
      s_hi[i] = s_end;
    }
    for (int i = 0; i < count; ++i) {
      nodes.b.push_back(b);
      nodes.t.push_back(x[i]);
      nodes.du_weight.push_back(2.0 * b * x[i] * w[i]);
      nodes.u_lo.push_back(b * (1.0 - std::min(s_hi[i], 1.0)));
      nodes.u_hi.push_back(b * (1.0 - s_lo[i]));
    }
    a = b;
  }
  nodes.real = nodes.size();
  for (double mu0 : mu0s) {
    nodes.incidences.push_back(nodes.size());
    nodes.b.push_back(n_above * n_above);
    nodes.t.push_back(mu0);
    nodes.du_weight.push_back(0.0);
    nodes.u_lo.push_back(n_above * n_above * (1.0 - mu0 * mu0));
    nodes.u_hi.push_back(nodes.u_lo.back());
  }
  return nodes;
}

// The nodes as one medium of index n sees them (1.).
struct Medium {
  double n = 1.0;
  std::vector<int> active;  // global indices of the nodes that exist here
  std::vector<double> mu;   // their cosines
  std::vector<double> W;    // their flux weights (0 for the incidence node)
  std::vector<double> x_lo, x_hi;  // their cells in mu^2 here (Nodes::u_lo, u_hi)
  int real = 0;             // active nodes with W > 0
};

Medium make_medium(const Nodes& nodes, double n) {
  Medium m;
  m.n = n;
  const double n2 = n * n;
  for (int j = 0; j < nodes.size(); ++j) {
    // mu^2 = 1 - u/n^2 with u = b (1 - t^2), written to keep precision in the top segment.
    const double mu2 = (n2 - nodes.b[j] + nodes.b[j] * nodes.t[j] * nodes.t[j]) / n2;
    const bool exists = j >= nodes.real ? mu2 > 0.0 : nodes.b[j] <= n2;
    if (!exists || !(mu2 > 0.0)) continue;
    m.active.push_back(j);
    m.mu.push_back(std::min(1.0, std::sqrt(mu2)));
    m.W.push_back(nodes.du_weight[j] / n2);
    m.x_lo.push_back(std::max(0.0, 1.0 - nodes.u_hi[j] / n2));
    m.x_hi.push_back(std::max(0.0, 1.0 - nodes.u_lo[j] / n2));
    if (nodes.du_weight[j] > 0.0) ++m.real;
  }
  return m;
}

// An element of the stack in flux form on all nodes (6.).
struct Element {
  Matrix Rt, Rb, Td, Tu;
  bool diagonal = false;  // all four matrices diagonal (an interface)
  // A stack under a rough top (solve_stack): Rt holds the light that entered the stack and came
  // back out, Rt_direct the top's own reflection (the glossy lobe), as the walk reports them.
  Matrix Rt_direct;
};

// x d for a diagonal d: column j of x scaled by d_jj. The same values as the general product,
// whose other terms are exact zeros, in O(n^2) instead of O(n^3).
Matrix times_diagonal(Matrix x, const Matrix& d) {
  for (int i = 0; i < x.n; ++i)
    for (int j = 0; j < x.n; ++j) x(i, j) *= d(j, j);
  return x;
}

// A over B from the bottom up: R_t and T_d of the combination (B needs only R_t and T_d; B.Td
// may be empty for an opaque B).
Element add_over(const Element& A, const Element& B) {
  const int n = A.Rt.n;
  const Matrix I = Matrix::identity(n);
  Element out;
  // An interface above (diagonal A) makes the right-hand products column scalings.
  auto right = [&](const Matrix& x, const Matrix& a) { return A.diagonal ? times_diagonal(x, a) : x * a; };
  const LU d2(I - right(B.Rt, A.Rb));
  out.Rt = A.Rt + A.Tu * d2.solve(right(B.Rt, A.Td));
  if (B.Td.n > 0) {
    const LU d1(I - A.Rb * B.Rt);
    out.Td = B.Td * d1.solve(A.Td);
  }
  return out;
}

Element interface_element(const Medium& above, const Medium& below, int size) {
  Element e{Matrix(size), Matrix(size), Matrix(size), Matrix(size), true, {}};
  std::vector<double> mu_above(size, -1.0), mu_below(size, -1.0);
  for (std::size_t k = 0; k < above.active.size(); ++k) mu_above[above.active[k]] = above.mu[k];
  for (std::size_t k = 0; k < below.active.size(); ++k) mu_below[below.active[k]] = below.mu[k];
  for (int j = 0; j < size; ++j) {
    const bool a = mu_above[j] > 0.0, b = mu_below[j] > 0.0;
    if (a && b) {
      // Fresnel reflectance is the same from both sides at Snell-related angles (Born and Wolf 1.5.3).
      const double r = fresnel_dielectric(mu_above[j], above.n, below.n);
      e.Rt(j, j) = e.Rb(j, j) = r;
      e.Td(j, j) = e.Tu(j, j) = 1.0 - r;
    } else if (a) {
      e.Rt(j, j) = 1.0;  // total internal reflection: the direction does not exist below
    } else if (b) {
      e.Rb(j, j) = 1.0;
    }
  }
  return e;
}

// Normalised associated Legendre functions Pt_l^m(x) = sqrt((l-m)!/(l+m)!) P_l^m(x) for
// l = 0..L-1 (0 for l < m), without the Condon-Shortley phase (only products of two enter), by
// the stable recurrences Pt_m^m = prod_{k=1..m} sqrt((2k-1)/(2k)) (1-x^2)^(m/2),
// Pt_{m+1}^m = sqrt(2m+1) x Pt_m^m, and
// sqrt(l^2-m^2) Pt_l^m = (2l-1) x Pt_{l-1}^m - sqrt((l-1)^2-m^2) Pt_{l-2}^m
// (Abramowitz and Stegun 8.5.3 rescaled). For m = 0 these are the Legendre polynomials.
void associated_legendre_all(int L, int m, double x, double* p) {
  for (int l = 0; l < std::min(L, m); ++l) p[l] = 0.0;
  if (m >= L) return;
  double pmm = 1.0;
  const double s2 = std::max(0.0, (1.0 - x) * (1.0 + x));
  for (int k = 1; k <= m; ++k) pmm *= std::sqrt((2.0 * k - 1.0) / (2.0 * k) * s2);
  p[m] = pmm;
  if (m + 1 < L) p[m + 1] = std::sqrt(2.0 * m + 1.0) * x * pmm;
  for (int l = m + 2; l < L; ++l)
    p[l] = ((2.0 * l - 1.0) * x * p[l - 1] - std::sqrt((l - 1.0) * (l - 1.0) - double(m) * m) * p[l - 2]) /
           std::sqrt(double(l) * l - double(m) * m);
}

// The delta-M truncation order of a layer in a medium (4.): the number of its nodes.
int truncation_order(const Medium& m) { return std::max(1, m.real); }

// A finite layer under a rough top is doubled on its medium's real nodes alone (10.): `m` without
// the incidences, whose cosines in it are `dropped` (empty otherwise). No light reaches an
// incidence node below a rough top, and the real nodes' numbers do not depend on it: nothing
// scatters into a node of weight zero, so its row of every R is 0 and of every T the diagonal
// alone, and its column enters the real nodes' products only as terms x * 0. What the doubling
// reads of it is kept: the smallest cosine (the starting thickness, 5.) and whether its
// diagonal of T still transmits (6.), exp-like, t -> t * t per doubling, exactly as the full
// matrices compute it.
struct DroppedNodes {
  std::vector<double> mu;
};
// Whether layer_element doubles the layer a fixed number of times (a finite optical depth), the
// case where the dropped nodes' part is tracked; otherwise it doubles until R stops changing,
// which looks at every column.
bool doubled_to_depth(const Layer& layer, int c) {
  return !layer.semi_infinite() && !std::isinf(layer.sigma_t()[c] * layer.thickness);
}

// The layer in channel c and azimuthal Fourier mode `mode` on the medium's nodes, embedded in
// `size` nodes (3.-6.; for mode >= 1 see 8.). For a semi-infinite layer Td and Tu are left empty.
Element layer_element(const Layer& layer, int c, const Medium& m, int size, int mode, int* doublings,
                      const DroppedNodes& dropped = {}) {
  const int na = static_cast<int>(m.active.size());
  const double sigma_t = layer.sigma_t()[c];
  // A finite layer whose optical depth overflows a double (coefficients or a thickness near the
  // double limit) transmits nothing (exp(-tau) = 0 long before) and reflects as its
  // semi-infinite limit, so it is solved as that limit with T = 0; halving an infinite starting
  // thickness (5.) would never reach the thin layer.
  const bool too_deep = !layer.semi_infinite() && std::isinf(sigma_t * layer.thickness);
  const bool semi = layer.semi_infinite() || too_deep;
  const double sigma_s = layer.sigma_s()[c];
  const double a = sigma_t > 0.0 ? sigma_s / sigma_t : 0.0;
  auto embed = [&](const Matrix& local) {
    Matrix g(size);
    for (int i = 0; i < na; ++i)
      for (int j = 0; j < na; ++j) g(m.active[i], m.active[j]) = local(i, j);
    return g;
  };
  Element e;
  if (!semi && (sigma_t == 0.0 || layer.thickness == 0.0)) {  // no layer at all
    Matrix I(na);
    for (int i = 0; i < na; ++i) I(i, i) = 1.0;
    e.Rt = e.Rb = Matrix(size);
    e.Td = e.Tu = embed(I);
    return e;
  }

  // 4. Moments and delta-M.
  const int M = truncation_order(m);
  std::vector<double> chi(M + 1, 0.0);
  if (sigma_s > 0.0)
    for (const PhaseLobe& lobe : layer.lobes) {
      const double w = lobe.sigma_s[c] / sigma_s, g = lobe.g[c];
      double gl = 1.0;
      for (int l = 0; l <= M; ++l, gl *= g) chi[l] += w * gl;
    }
  // Delta-M truncates forward peaks only: f is the M-th moment of the lobes with g > 0 (a
  // backward lobe's g^M, positive for even M, is no forward peak and would make the truncated
  // moments (chi_l - f)/(1 - f) explode as g -> -1).
  double f = 0.0;
  if (a > 0.0)
    for (const PhaseLobe& lobe : layer.lobes)
      if (lobe.g[c] > 0.0) f += lobe.sigma_s[c] / sigma_s * std::pow(lobe.g[c], M);
  const double a_scaled = a > 0.0 ? a * (1.0 - f) / (1.0 - a * f) : 0.0;
  const double tau_scale = 1.0 - a * f;  // tau' = tau (1 - a f)

  Matrix alpha(na), beta(na);
  for (int i = 0; i < na; ++i) alpha(i, i) = 1.0 / m.mu[i];
  if (a_scaled > 0.0 && mode < M) {
    std::vector<double> P(static_cast<std::size_t>(na) * M);
    for (int i = 0; i < na; ++i) associated_legendre_all(M, mode, m.mu[i], &P[static_cast<std::size_t>(i) * M]);
    std::vector<double> coef(M);  // (2l + 1) chi'_l / (4 pi)
    for (int l = 0; l < M; ++l) coef[l] = (2.0 * l + 1.0) * (chi[l] - f) / (1.0 - f) / (4.0 * kPi);
    Matrix Kp(na), Km(na);
    for (int j = 0; j < na; ++j) {
      const double* pj = &P[static_cast<std::size_t>(j) * M];
      double norm = 0.0;
      for (int i = 0; i < na; ++i) {
        const double* pi = &P[static_cast<std::size_t>(i) * M];
        double same = 0.0, opposite = 0.0;  // p0(mu_i, mu_j), p0(mu_i, -mu_j)
        for (int l = 0; l < M; ++l) {
          const double term = coef[l] * pi[l] * pj[l];
          same += term;
          opposite += ((l + mode) % 2 == 0) ? term : -term;  // Pt_l^m(-x) = (-1)^(l+m) Pt_l^m(x)
        }
        Kp(i, j) = kPi * m.W[i] * same / (m.mu[i] * m.mu[j]);
        Km(i, j) = kPi * m.W[i] * opposite / (m.mu[i] * m.mu[j]);
        norm += m.mu[j] * (Kp(i, j) + Km(i, j));
      }
      // 3.: renormalise the column so that one scattering conserves power exactly (mode 0
      // only: the higher modes carry no power of their own).
      if (mode == 0 && norm > 0.0)
        for (int i = 0; i < na; ++i) {
          Kp(i, j) /= norm;
          Km(i, j) /= norm;
        }
    }
    alpha = alpha - scaled(Kp, a_scaled);
    beta = scaled(Km, a_scaled);
  }

  // 5. Starting thickness and the diamond initialisation.
  double mu_min = 1.0;
  for (double mu : m.mu) mu_min = std::min(mu_min, mu);
  for (double mu : dropped.mu) mu_min = std::min(mu_min, mu);
  int steps = 0;
  double delta;
  if (semi) {
    delta = mu_min / 2.0;
  } else {
    delta = sigma_t * layer.thickness * tau_scale;  // finite (too_deep above): at most ~1100 halvings
    while (delta > mu_min) {
      delta /= 2.0;
      ++steps;
    }
  }
  const Matrix I = Matrix::identity(na);
  const double h = delta / 2.0;
  const Matrix S = I + scaled(alpha, h), D = scaled(beta, h), P = I - scaled(alpha, h);
  const Matrix A_plus = LU(S - D).solve(P + D), A_minus = LU(S + D).solve(P - D);
  Matrix T = scaled(A_plus + A_minus, 0.5), R = scaled(A_plus - A_minus, 0.5);
  // The dropped nodes' diagonal of T: the diamond initialisation of a node nothing scatters into,
  // (1 - h/mu) / (1 + h/mu), in the operations of the matrices above.
  std::vector<double> dropped_T;
  for (double mu : dropped.mu) {
    const double ah = (1.0 / mu) * h;
    dropped_T.push_back((1.0 - ah) * (1.0 / (1.0 + ah)));
  }

  // 6. Doubling.
  auto double_once = [&]() {
    const Matrix Y = LU(I - R * R).solve(T);  // (I - R R)^-1 T
    Matrix R2 = R + T * (R * Y);
    T = T * Y;
    for (double& t : dropped_T) t = std::abs(t * t) < 1e-200 ? 0.0 : t * t;  // (I - R R) is 1 there
    const double change = [&] {
      double c2 = 0.0;
      for (std::size_t k = 0; k < R.a.size(); ++k) c2 = std::max(c2, std::abs(R2.a[k] - R.a[k]));
      return c2;
    }();
    R = std::move(R2);
    // Powers below 1e-200 (a beam's exp(-tau/mu) at grazing nodes of a thick layer) are zero
    // for every total; flushing them keeps the arithmetic out of subnormal numbers, which are
    // tens of times slower.
    for (Matrix* x : {&R, &T})
      for (double& v : x->a)
        if (std::abs(v) < 1e-200) v = 0.0;
    ++*doublings;
    return change;
  };
  if (semi) {
    // Doubled until R stops changing; at most to tau' = 1e8: without absorption R approaches 1
    // only as 1 - R ~ 1/tau, while I - R R grows ill-conditioned (rounding ~ tau * 1e-16), so
    // beyond 1e8 rounding would cost more than the remaining ~1e-8 of unconverged reflection.
    // A conservative medium (sigma_a = 0) returns every photon that enters it (R's columns sum
    // to 1 exactly), so there the 1/tau tail is not waited for: doubling stops at tau' = 1e6
    // (rounding ~1e-10) and the columns are scaled to 1, which puts the last ~1e-5 of the
    // reflected power in the directions of the rest.
    const bool conservative = layer.sigma_a[c] == 0.0 && mode == 0;
    const double max_thickness = conservative ? 1e6 : 1e8;
    double thickness = delta;
    for (int k = 0; k < 100 && thickness < max_thickness; ++k, thickness *= 2.0)
      if (double_once() < 1e-13 && k > 4) break;
    if (conservative)
      for (int j = 0; j < na; ++j) {
        double sum = 0.0;
        for (int i = 0; i < na; ++i) sum += R(i, j);
        if (sum > 0.0)
          for (int i = 0; i < na; ++i) R(i, j) /= sum;
      }
    e.Rt = e.Rb = embed(R);
    if (too_deep) e.Td = e.Tu = Matrix(size);
    return e;
  }
  // Once T is exactly 0 (every power below the flush of double_once), a doubling adds T (...) = 0
  // to R and keeps T = 0: the remaining steps change nothing, and an astronomically thick layer
  // (up to ~1100 steps) need not take them.
  auto transmits = [&] {
    auto nonzero = [](double v) { return v != 0.0; };
    return std::any_of(T.a.begin(), T.a.end(), nonzero) || std::any_of(dropped_T.begin(), dropped_T.end(), nonzero);
  };
  for (int k = 0; k < steps && transmits(); ++k) double_once();
  e.Rt = e.Rb = embed(R);
  e.Td = e.Tu = embed(T);
  return e;
}

// A layer without scattering (11.: the unscattered solution), exactly: R = 0 and T diagonal,
// exp(-tau / mu) per node (the beam's attenuation along its path); the same as layer_element's
// doubling of it, without the doubling.
Element absorbing_layer_element(const Layer& layer, int c, const Medium& m, int size) {
  Element e{Matrix(size), Matrix(size), Matrix(), Matrix(), true, {}};
  if (layer.semi_infinite()) {
    e.diagonal = false;
    return e;  // nothing comes back; Td empty as layer_element's
  }
  e.Td = e.Tu = Matrix(size);
  const double tau = layer.sigma_t()[c] * layer.thickness;
  for (std::size_t k = 0; k < m.active.size(); ++k) {
    const int j = m.active[k];
    e.Td(j, j) = e.Tu(j, j) = std::isinf(tau) ? 0.0 : std::exp(-tau / m.mu[k]);
  }
  return e;
}

Element lambert_element(const Spectrum& albedo, int c, const Medium& m, int size, int mode) {
  Element e;
  e.Rt = Matrix(size);
  if (mode > 0) return e;  // isotropic reflection has no azimuthal modes (8.)
  for (std::size_t i = 0; i < m.active.size(); ++i)
    for (std::size_t j = 0; j < m.active.size(); ++j) e.Rt(m.active[i], m.active[j]) = albedo[c] * m.W[i];
  return e;
}

// A rough interface of the stack on the solver's basis (10.): interface k (0 the top, N the
// bottom), its projection on every mode the solution uses, the incidences' columns apart (the
// nodes' are cached: the same for every incidence), and where they sit among the nodes.
struct RoughInterface {
  std::shared_ptr<const InterfaceFourier> f;
  std::shared_ptr<const BeamFourier> beams;
  std::vector<int> above, below, incidence;  // global node indices
  // Its elements per mode (rough_interface_element), made once: the interface is grey, so every
  // channel, and the unscattered solution, adds the same one. At the top, Rt is kept apart in
  // direct[mode] and the element's Rt is 0 (10.).
  std::vector<Element> elements;
  std::vector<Matrix> direct;
  // 13. A diffuse interface (f null): its elements per mode, made once (diffuse_interface_element).
  bool diffuse = false;
  // The interface is added by its own elements, not as a smooth Fresnel diagonal.
  bool full() const { return f != nullptr || diffuse; }
};

// The discretised stack for a set of incidence cosines.
struct Problem {
  const LayerStack* stack = nullptr;
  Nodes nodes;
  Medium above, below;  // below: only for a transmitting stack
  std::vector<Medium> media;
  bool lambert = false, semi = false, transmits = false;
  // rough[k]: interface k if it is rough (its f set) or diffuse, else smooth; rough_top: rough[0]
  // is rough.
  std::vector<RoughInterface> rough;
  bool rough_top = false;
  // Under a rough top: each finite layer's medium without the incidences, and their cosines there
  // (DroppedNodes); empty otherwise.
  std::vector<Medium> layer_media;
  std::vector<DroppedNodes> dropped;
  // Energy-conserving rough interfaces (11.): the same stack without scattering, whose solution is
  // the unscattered light (the walk's R_specular and T_ballistic); null otherwise.
  std::shared_ptr<const LayerStack> unscattered;
  int size() const { return nodes.size(); }
};

// 10. Rough interface k of mode `mode` on all nodes: the projected blocks (interface_fourier.h)
// embedded at the real nodes of the media above and below it, and the incidences' columns.
// Not diagonal. `single`: the first order's reflection from above alone (Rt, the rest empty).
Element rough_interface_element(const Problem& p, int k, int size, int mode, bool single = false) {
  Element e{Matrix(size), Matrix(size), Matrix(size), Matrix(size), false, {}};
  const RoughInterface& r = p.rough[k];
  const InterfaceFourier& f = *r.f;
  if (mode >= f.modes) return e;
  auto embed = [&](const std::vector<double>& block, const std::vector<int>& to, const std::vector<int>& from, Matrix* m) {
    const std::size_t cols = from.size();
    for (std::size_t i = 0; i < to.size(); ++i)
      for (std::size_t j = 0; j < cols; ++j) (*m)(to[i], from[j]) = block[i * cols + j];
  };
  if (single) {
    embed(f.Rt_single[mode], r.above, r.above, &e.Rt);
    embed(r.beams->Rt_single[mode], r.above, r.incidence, &e.Rt);
    return e;
  }
  embed(f.Rt[mode], r.above, r.above, &e.Rt);
  embed(f.Td[mode], r.below, r.above, &e.Td);
  embed(f.Rb[mode], r.below, r.below, &e.Rb);
  embed(f.Tu[mode], r.above, r.below, &e.Tu);
  embed(r.beams->Rt[mode], r.above, r.incidence, &e.Rt);
  embed(r.beams->Td[mode], r.below, r.incidence, &e.Td);
  return e;
}

// 13. Diffuse interface k (materials/interfaces/diffuse_interface.h) of mode `mode` on all nodes.
// Light side (index n_lo): node j reflects F_j = F(mu_j) into itself (every mode: Fresnel does
// not depend on azimuth) and transmits 1 - F_j into the dense side's real nodes in proportion to
// their W (Lambert's law, 7.). Dense side (n_hi): every node transmits t_hi into the light
// side's real nodes in proportion to (1 - F_i) W_i and reflects 1 - t_hi in proportion to W
// (Lambert). The diffuse parts are mode 0 alone (isotropic in azimuth, 8.). Normalised on the
// nodes: with S_hi = sum W_hi and tau_lo = sum_i (1 - F_i) W_lo,i,
// Td(i, j) = (1 - F_j) W_hi,i / S_hi and Tu(j, i) = t_hi (1 - F_j) W_lo,j / tau_lo with
// t_hi = (n_lo/n_hi)^2 tau_lo / S_hi, so every column sums to 1 exactly (no loss, whatever the
// order) and M_ij / (n_i^2 W_i) = M_ji / (n_j^2 W_j) holds exactly: reciprocity in flux form (the
// nodes' etendue n^2 W is the same measure du on both sides, 1.). As S -> 1 and tau_lo ->
// 1 - rbar_lo with the order, t_hi -> (n_lo/n_hi)^2 (1 - rbar_lo), the interface's own.
Element diffuse_interface_element(const Problem& p, int k, int size, int mode) {
  const int nl = static_cast<int>(p.stack->layers.size());
  const Medium& a = k == 0 ? p.above : p.media[k - 1];
  const Medium& b = k == nl ? p.below : p.media[k];
  Element e{Matrix(size), Matrix(size), Matrix(size), Matrix(size), false, {}};
  const bool light_above = a.n < b.n;
  const Medium& lo = light_above ? a : b;
  const Medium& hi = light_above ? b : a;
  Matrix& R_lo = light_above ? e.Rt : e.Rb;  // reflection on the light side
  Matrix& R_hi = light_above ? e.Rb : e.Rt;
  Matrix& T_up = light_above ? e.Td : e.Tu;  // light side -> dense side
  Matrix& T_down = light_above ? e.Tu : e.Td;
  std::vector<double> F(lo.active.size());
  double s_hi = 0.0, tau_lo = 0.0;
  for (std::size_t q = 0; q < lo.active.size(); ++q) {
    F[q] = fresnel_dielectric(lo.mu[q], lo.n, hi.n);
    R_lo(lo.active[q], lo.active[q]) = F[q];
    tau_lo += (1.0 - F[q]) * lo.W[q];
  }
  if (mode > 0) return e;
  for (double w : hi.W) s_hi += w;
  const double t_hi = (lo.n / hi.n) * (lo.n / hi.n) * tau_lo / s_hi;
  for (std::size_t j = 0; j < lo.active.size(); ++j)
    for (std::size_t i = 0; i < hi.active.size(); ++i) T_up(hi.active[i], lo.active[j]) = (1.0 - F[j]) * hi.W[i] / s_hi;
  for (std::size_t j = 0; j < hi.active.size(); ++j) {
    for (std::size_t i = 0; i < lo.active.size(); ++i)
      T_down(lo.active[i], hi.active[j]) = t_hi * (1.0 - F[i]) * lo.W[i] / tau_lo;
    for (std::size_t i = 0; i < hi.active.size(); ++i) R_hi(hi.active[i], hi.active[j]) = (1.0 - t_hi) * hi.W[i] / s_hi;
  }
  return e;
}

// A medium's real nodes (W > 0) as the projection's directions, and their global indices.
FourierDirections real_directions(const Medium& m, std::vector<int>* global) {
  FourierDirections d;
  for (std::size_t k = 0; k < m.active.size(); ++k) {
    if (m.W[k] == 0.0) continue;
    d.mu.push_back(m.mu[k]);
    d.x_lo.push_back(m.x_lo[k]);
    d.x_hi.push_back(m.x_hi[k]);
    global->push_back(m.active[k]);
  }
  return d;
}

// 11. The stack without scattering: every layer's scattering becomes absorption (the same
// extinction), a Lambert substrate black. Its solution is the light that left without meeting a
// particle or the substrate -- through and between rough interfaces too, where it is spread and
// no closed form (zeroth_order) applies.
LayerStack without_scattering(LayerStack s) {
  for (Layer& l : s.layers) {
    l.sigma_a = l.sigma_t();
    for (PhaseLobe& lobe : l.lobes) lobe.sigma_s = Spectrum(0.0);
  }
  if (s.below.kind == Below::Kind::Lambert) s.below.albedo = Spectrum(0.0);
  return s;
}

Problem make_problem(const LayerStack& stack, const std::vector<double>& cos_theta_i,
                     const AddingDoublingSettings& settings, const char* who, int rough_modes = -1) {
  for (double mu : cos_theta_i)
    if (!(mu > 0.0 && mu <= 1.0)) throw std::invalid_argument(std::string(who) + ": cos_theta_i must be in (0, 1]");
  if (settings.quadrature_points < 2)
    throw std::invalid_argument(std::string(who) + ": quadrature_points must be at least 2");
  if (stack.layers.empty()) throw std::invalid_argument(std::string(who) + ": the stack has no layers");
  Problem p;
  p.stack = &stack;
  p.lambert = stack.below.kind == Below::Kind::Lambert;
  p.semi = stack.layers.back().semi_infinite();
  p.transmits = !p.lambert && !p.semi;
  std::vector<double> indices{stack.above_ior};
  for (const Layer& l : stack.layers) indices.push_back(l.ior);
  if (p.transmits) indices.push_back(stack.below.ior);
  p.nodes = make_nodes(indices, stack.above_ior, cos_theta_i, settings.quadrature_points);
  p.above = make_medium(p.nodes, stack.above_ior);
  for (const Layer& l : stack.layers) p.media.push_back(make_medium(p.nodes, l.ior));
  if (p.transmits) p.below = make_medium(p.nodes, stack.below.ior);
  const int nl = static_cast<int>(stack.layers.size());
  p.rough.resize(nl + 1);
  // rough_modes: -1 every mode any layer uses (brdf_tables_adding_doubling's `modes`), 1 mode 0
  // alone (the totals), 0 none (the media alone). The projection is the same for every channel
  // (the indices are grey).
  if (rough_modes == 0) return p;
  int modes = 1;
  if (rough_modes < 0)
    for (const Medium& m : p.media) modes = std::max(modes, truncation_order(m));
  // Interface k between the media above and below it; its beams: the incidences' nodes as they
  // exist in the medium above it (their cosines there).
  auto project = [&](int k, double alpha, bool energy_conserving) {
    const Medium& above = k == 0 ? p.above : p.media[k - 1];
    const Medium& below = k == nl ? p.below : p.media[k];
    RoughInterface& r = p.rough[k];
    const FourierDirections a = real_directions(above, &r.above);
    const FourierDirections b = real_directions(below, &r.below);
    FourierDirections beams;
    for (std::size_t q = 0; q < above.active.size(); ++q) {
      const int j = above.active[q];
      if (j < p.nodes.real) continue;
      // At the top, the incidence's cosine itself (make_nodes).
      const double mu = k == 0 ? p.nodes.t[j] : above.mu[q];
      beams.mu.push_back(mu);
      beams.x_lo.push_back(mu * mu);
      beams.x_hi.push_back(mu * mu);
      r.incidence.push_back(j);
    }
    if (energy_conserving) {
      r.f = std::make_shared<InterfaceFourier>(project_microsurface(alpha, above.n, below.n, a, b, modes));
      r.beams = std::make_shared<BeamFourier>(project_microsurface_beams(alpha, above.n, below.n, beams, a, b, modes));
    } else {
      r.f = std::make_shared<InterfaceFourier>(project_interface(alpha, above.n, below.n, settings.rough_eval, a, b, modes));
      r.beams = std::make_shared<BeamFourier>(project_beams(alpha, above.n, below.n, settings.rough_eval, beams, a, b, modes));
    }
  };
  if (stack.single_scattering_top()) project(0, stack.top_roughness, false);
  auto make_elements = [&](int k) {
    RoughInterface& r = p.rough[k];
    for (int mode = 0; mode < modes; ++mode) {
      r.elements.push_back(rough_interface_element(p, k, p.size(), mode));
      if (k > 0) continue;
      r.direct.push_back(std::move(r.elements.back().Rt));
      r.elements.back().Rt = Matrix(p.size());
    }
  };
  for (int k = 0; k <= nl; ++k)
    if (const double alpha = stack.energy_conserving_alpha(k); alpha > 0.0 && (k < nl || p.transmits)) project(k, alpha, true);
  p.rough_top = p.rough[0].f != nullptr;
  for (int k = 0; k <= nl; ++k)
    if (p.rough[k].f) make_elements(k);
  for (int k = 0; k <= nl; ++k)
    if (stack.diffuse_interface(k) && (k < nl || p.transmits)) {
      p.rough[k].diffuse = true;
      for (int mode = 0; mode < modes; ++mode) p.rough[k].elements.push_back(diffuse_interface_element(p, k, p.size(), mode));
    }
  if (p.rough_top && !adding_doubling_test_hooks::double_on_every_node)
    for (const Medium& m : p.media) {
      Medium real = m;
      DroppedNodes d;
      real.active.clear();
      real.mu.clear();
      real.W.clear();
      real.x_lo.clear();
      real.x_hi.clear();
      for (std::size_t k = 0; k < m.active.size(); ++k) {
        if (m.active[k] >= p.nodes.real) {
          d.mu.push_back(m.mu[k]);
          continue;
        }
        real.active.push_back(m.active[k]);
        real.mu.push_back(m.mu[k]);
        real.W.push_back(m.W[k]);
        real.x_lo.push_back(m.x_lo[k]);
        real.x_hi.push_back(m.x_hi[k]);
      }
      p.layer_media.push_back(std::move(real));
      p.dropped.push_back(std::move(d));
    }
  // 11. and 13.: light through a diffuse interface is spread as through a rough one.
  if (stack.energy_conserving_rough() || stack.any_diffuse_interface())
    p.unscattered = std::make_shared<LayerStack>(without_scattering(stack));
  return p;
}

// 10. Under a rough top, the layers of one medium at the bottom of a stack over a Lambert
// substrate: added on that medium's real nodes alone (compact matrices, no incidence; the
// substrate's column for the incidence is never reached below a rough top), then embedded in
// all nodes. The numbers are those of the full matrices, whose other rows and columns add only
// terms x * 0 to the products and identity rows to the solves. Returns R_t; *next: the layer
// above the run.
Element add_bottom_run(const Problem& p, const LayerStack& stack, int c, int mode, int* doublings, int* next) {
  const int nl = static_cast<int>(stack.layers.size()), size = p.size();
  const Medium& m = p.layer_media[nl - 1];
  Medium local = m;  // the same nodes, numbered 0..n-1
  const int n = static_cast<int>(m.active.size());
  for (int i = 0; i < n; ++i) local.active[i] = i;
  Element acc = add_over(layer_element(stack.layers[nl - 1], c, local, n, mode, doublings, p.dropped[nl - 1]),
                         lambert_element(stack.below.albedo, c, local, n, mode));
  int k = nl - 2;
  for (; k >= 0 && !p.rough[k + 1].full() && stack.layers[k].ior == stack.layers[k + 1].ior && doubled_to_depth(stack.layers[k], c);
       --k) {
    const Layer& layer = stack.layers[k];
    // The clear layer of solve_stack is skipped as there.
    if (layer.sigma_t()[c] == 0.0 && static_cast<int>(p.media[k].active.size()) == size) continue;
    acc = add_over(layer_element(layer, c, local, n, mode, doublings, p.dropped[k]), acc);
  }
  *next = k;
  Element out;
  out.Rt = Matrix(size);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) out.Rt(m.active[i], m.active[j]) = acc.Rt(i, j);
  return out;
}

// R_t and T_d of the whole stack (or of `stack`, the same layers' structure: the unscattered
// copy of 11.) in channel c and Fourier mode `mode`, added from the bottom up (6.); T_d is empty
// unless the stack transmits.
Element solve_stack(const Problem& p, int c, int mode, int* doublings, const LayerStack* other = nullptr) {
  const LayerStack& stack = other ? *other : *p.stack;
  const int nl = static_cast<int>(stack.layers.size()), size = p.size();
  // Layer k in channel c. The unscattered copy's layers are exact diagonals (no doubling); under a
  // rough top a finite layer is doubled on the real nodes alone (DroppedNodes).
  auto layer_element = [&](int k) {
    const Layer& layer = stack.layers[k];
    if (other) return absorbing_layer_element(layer, c, p.media[k], size);
    if (!p.layer_media.empty() && doubled_to_depth(layer, c))
      return lamina::layer_element(layer, c, p.layer_media[k], size, mode, doublings, p.dropped[k]);
    return lamina::layer_element(layer, c, p.media[k], size, mode, doublings);
  };
  Element acc;
  int k = nl - 2;  // the next layer to add
  if (!other && !p.layer_media.empty() && p.lambert && !p.semi && doubled_to_depth(stack.layers[nl - 1], c)) {
    acc = add_bottom_run(p, stack, c, mode, doublings, &k);
  } else if (p.semi) {
    acc = layer_element(nl - 1);
    acc.Td = Matrix();
  } else {
    const Element bottom = p.lambert       ? lambert_element(stack.below.albedo, c, p.media[nl - 1], size, mode)
                           : p.rough[nl].full() ? Element()
                                                : interface_element(p.media[nl - 1], p.below, size);
    acc = add_over(layer_element(nl - 1), p.rough[nl].full() ? p.rough[nl].elements[mode] : bottom);
    if (p.lambert) acc.Td = Matrix();
  }
  for (; k >= 0; --k) {
    if (p.rough[k + 1].full())
      acc = add_over(p.rough[k + 1].elements[mode], acc);
    else if (stack.layers[k].ior != stack.layers[k + 1].ior)
      acc = add_over(interface_element(p.media[k], p.media[k + 1], size), acc);
    // A layer that neither scatters nor absorbs (a clear coat) in a medium where every node
    // exists is the identity (R = 0, T = I), and adding it returns the part below unchanged
    // (every product and solve is with I): skipped. Where some node does not exist in it, its
    // T is 0 there and it is added.
    const Layer& layer = stack.layers[k];
    if (layer.sigma_t()[c] == 0.0 && !layer.semi_infinite() && static_cast<int>(p.media[k].active.size()) == size) continue;
    acc = add_over(layer_element(k), acc);
  }
  if (p.rough_top) {
    // 10. The top's own reflection is kept apart (Rt_direct) and the rest added as usual.
    acc = add_over(p.rough[0].elements[mode], acc);
    acc.Rt_direct = p.rough[0].direct[mode];
  } else if (p.rough[0].diffuse) {
    acc = add_over(p.rough[0].elements[mode], acc);
  } else if (stack.above_ior != stack.layers[0].ior) {
    acc = add_over(interface_element(p.above, p.media[0], size), acc);
  }
  return acc;
}

// Column j of an element's reflection (its top's own included) and transmission.
std::pair<double, double> column_sums(const Element& e, int j) {
  double r = 0.0, t = 0.0;
  for (int i = 0; i < e.Rt.n; ++i) {
    r += e.Rt(i, j);
    if (e.Rt_direct.n > 0) r += e.Rt_direct(i, j);
    if (e.Td.n > 0) t += e.Td(i, j);
  }
  return {r, t};
}

// 11. Energy-conserving rough interfaces: the totals split as the walk's, R_specular and
// T_ballistic the unscattered solution's (u), the rest diffuse; R_hemispherical_glossy the
// unscattered part of the diffuse-incidence reflection.
void fill_totals_unscattered(const Problem& p, const Element& acc, const Element& u, int c, int j0,
                             AddingDoublingTotals* out) {
  const auto [R, T] = column_sums(acc, j0);
  const auto [UR, UT] = column_sums(u, j0);
  double Rh = 0.0, Th = 0.0, Rh_u = 0.0;
  for (std::size_t k = 0; k < p.above.active.size(); ++k) {
    if (p.above.W[k] == 0.0) continue;
    const int j = p.above.active[k];
    const auto [r, t] = column_sums(acc, j);
    Rh += p.above.W[k] * r;
    Th += p.above.W[k] * t;
    Rh_u += p.above.W[k] * column_sums(u, j).first;
  }
  out->R_specular[c] = UR;
  out->R_diffuse[c] = R - UR;
  out->T_ballistic[c] = UT;
  out->T_diffuse[c] = T - UT;
  out->absorbed[c] = 1.0 - R - T;
  out->R_hemispherical[c] = Rh;
  out->T_hemispherical[c] = Th;
  out->absorbed_hemispherical[c] = 1.0 - Rh - Th;
  out->R_hemispherical_glossy[c] = Rh_u;
}

void fill_totals(const Problem& p, const Element& acc, const ZerothOrder& z, int c, int j0, AddingDoublingTotals* out) {
  const int size = p.size();
  // Collimated: the column of the incidence node; diffuse: the columns weighted by W (2.).
  double R = 0.0, T = 0.0;
  for (int i = 0; i < size; ++i) {
    R += acc.Rt(i, j0);
    if (acc.Td.n > 0) T += acc.Td(i, j0);
  }
  // 10. Under a rough top nothing is unscattered but the top's own reflection (the glossy lobe),
  // which is R_specular, as in the walk's totals; the rest of R and all of T are diffuse.
  const bool rough = acc.Rt_direct.n > 0;
  double glossy = 0.0;
  if (rough)
    for (int i = 0; i < size; ++i) glossy += acc.Rt_direct(i, j0);
  double Rh = 0.0, Th = 0.0, Rh_glossy = 0.0;
  for (std::size_t k = 0; k < p.above.active.size(); ++k) {
    const int j = p.above.active[k];
    if (p.above.W[k] == 0.0) continue;
    double r = 0.0, t = 0.0, g = 0.0;
    for (int i = 0; i < size; ++i) {
      r += acc.Rt(i, j);
      if (rough) g += acc.Rt_direct(i, j);
      if (acc.Td.n > 0) t += acc.Td(i, j);
    }
    Rh += p.above.W[k] * (r + g);
    Rh_glossy += p.above.W[k] * g;
    Th += p.above.W[k] * t;
  }
  out->R_hemispherical_glossy[c] = Rh_glossy;
  if (rough) {
    out->R_specular[c] = glossy;
    out->T_ballistic[c] = 0.0;
    out->R_diffuse[c] = R;
    out->T_diffuse[c] = T;
    out->absorbed[c] = 1.0 - R - glossy - T;
  } else {
    out->R_specular[c] = z.R_specular[c];
    out->T_ballistic[c] = z.T_ballistic[c];
    out->R_diffuse[c] = R - z.R_specular[c];
    out->T_diffuse[c] = T - z.T_ballistic[c];
    out->absorbed[c] = 1.0 - R - T;
  }
  out->R_hemispherical[c] = Rh;
  out->T_hemispherical[c] = Th;
  out->absorbed_hemispherical[c] = 1.0 - Rh - Th;
}

}  // namespace

ZerothOrder zeroth_order_above_rough(const LayerStack& stack, double cos_theta_i) {
  if (!stack.energy_conserving_rough() && !stack.any_diffuse_interface()) return zeroth_order(stack, cos_theta_i);
  // The stack down to the first rough (or diffuse) interface, over a black substrate (which has
  // no interface and reflects nothing unscattered): the light that met no rough interface.
  const int first = [&] {
    int k = 0;
    while (!(stack.energy_conserving_alpha(k) > 0.0) && !stack.diffuse_interface(k)) ++k;
    return k;
  }();
  if (first == 0) {
    ZerothOrder z = zeroth_order(stack, cos_theta_i);
    z.R_specular = z.T_ballistic = Spectrum(0.0);
    // A diffuse top seen from its less dense side is a mirror F(mu) for the light it reflects
    // (13.: the solver keeps that light in the incidence node); from the dense side it reflects
    // by Lambert's law, and a rough top spreads its reflection: no delta lobe.
    if (stack.diffuse_interface(0) && stack.above_ior < stack.layers[0].ior)
      z.R_specular = Spectrum(fresnel_dielectric(cos_theta_i, stack.above_ior, stack.layers[0].ior));
    return z;
  }
  LayerStack above = stack;
  above.layers.resize(first);
  above.below.kind = Below::Kind::Lambert;
  above.below.albedo = Spectrum(0.0);
  ZerothOrder z = zeroth_order(stack, cos_theta_i);
  z.R_specular = zeroth_order(above, cos_theta_i).R_specular;
  z.T_ballistic = Spectrum(0.0);
  return z;
}

AddingDoublingTotals adding_doubling_totals(const LayerStack& stack, double cos_theta_i,
                                            const AddingDoublingSettings& settings) {
  const Problem p = make_problem(stack, {cos_theta_i}, settings, "adding_doubling_totals", 1);
  AddingDoublingTotals out;
  out.nodes = p.nodes.real;
  const ZerothOrder z = zeroth_order(stack, cos_theta_i);
  for (int c = 0; c < kChannels; ++c)
    if (settings.only_channel < 0 || settings.only_channel == c)
    {
      const Element acc = solve_stack(p, c, 0, &out.doublings);
      if (p.unscattered)
        fill_totals_unscattered(p, acc, solve_stack(p, c, 0, &out.doublings, p.unscattered.get()), c,
                                p.nodes.incidences[0], &out);
      else
        fill_totals(p, acc, z, c, p.nodes.incidences[0], &out);
    }
  return out;
}

namespace {

// The outgoing radiance of one Fourier mode as a function of the cosine in an outside medium
// (8.): node values L_i = F_i / (pi W_i), interpolated by a Lagrange polynomial in the segment
// parameter t over the nodes of the segment that holds the direction (the radiance is smooth in
// the cosine within a segment, and may have a kink where a segment ends: a critical angle).
struct ModeRadiance {
  const Problem* p = nullptr;
  const Medium* medium = nullptr;
  std::vector<double> segment_b;                 // segment tops (n^2) seen by this medium, ascending
  std::vector<std::vector<double>> t, value;     // per segment: node parameters and radiances

  void build(const Problem& problem, const Medium& m, const Matrix& M, int j0) {
    p = &problem;
    medium = &m;
    segment_b.clear();
    t.clear();
    value.clear();
    for (std::size_t k = 0; k < m.active.size(); ++k) {
      if (m.W[k] == 0.0) continue;
      const int j = m.active[k];
      const double b = problem.nodes.b[j];
      std::size_t s = 0;
      while (s < segment_b.size() && segment_b[s] != b) ++s;
      if (s == segment_b.size()) {
        segment_b.push_back(b);
        t.emplace_back();
        value.emplace_back();
      }
      t[s].push_back(problem.nodes.t[j]);
      value[s].push_back(M(j, j0) / (kPi * m.W[k]));
    }
  }
  // The segment ends in this medium's cosine, descending in u: mu at u = b_s.
  double operator()(double mu) const {
    const double n2 = medium->n * medium->n;
    const double u = n2 * (1.0 - mu * mu);
    std::size_t s = 0;
    while (s + 1 < segment_b.size() && u > segment_b[s]) ++s;
    const double b = segment_b[s];
    const double ts = std::sqrt(std::max(0.0, 1.0 - u / b));
    const std::vector<double>& x = t[s];
    const std::vector<double>& y = value[s];
    double sum = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      double l = 1.0;
      for (std::size_t k = 0; k < x.size(); ++k)
        if (k != i) l *= (ts - x[k]) / (x[i] - x[k]);
      sum += l * y[i];
    }
    return sum;
  }
  // int_lo^hi L(mu) mu dmu, Gauss-Legendre in x = mu^2 (mu dmu = dx/2) on each piece between
  // the segment ends.
  double integral(double lo, double hi) const {
    const double n2 = medium->n * medium->n;
    std::vector<double> cuts{lo * lo, hi * hi};
    for (double b : segment_b) {
      const double x = 1.0 - b / n2;  // mu^2 at u = b
      if (x > lo * lo && x < hi * hi) cuts.push_back(x);
    }
    std::sort(cuts.begin(), cuts.end());
    constexpr int kPoints = 8;
    static const GaussLegendreRule rule(kPoints);  // its roots once, not per piece
    double xs[kPoints], ws[kPoints], sum = 0.0;
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
      rule.apply(cuts[k], cuts[k + 1], xs, ws);
      for (int i = 0; i < kPoints; ++i) sum += 0.5 * ws[i] * (*this)(std::sqrt(xs[i]));
    }
    return sum;
  }
};

}  // namespace

std::vector<BrdfTable> brdf_tables_adding_doubling(const LayerStack& stack, const BrdfOptions& options,
                                                   const std::vector<double>& theta_i_deg,
                                                   const AddingDoublingSettings& settings,
                                                   std::vector<AddingDoublingTotals>* totals) {
  const int n_inc = static_cast<int>(theta_i_deg.size());
  if (n_inc == 0) return {};
  std::vector<double> mu0(n_inc);
  std::vector<BrdfOptions> opts(n_inc, options);
  for (int q = 0; q < n_inc; ++q) {
    opts[q].theta_i_deg = theta_i_deg[q];
    mu0[q] = incident_direction(theta_i_deg[q], options.phi_i_deg).z;
  }
  const Problem p = make_problem(stack, mu0, settings, "brdf_table_adding_doubling");
  const int K = options.bins_theta, Mphi = options.bins_phi;
  std::vector<BrdfTable> tables(n_inc);
  std::vector<ZerothOrder> z(n_inc);
  std::vector<AddingDoublingTotals> t(n_inc);
  std::vector<std::vector<Spectrum>> value(n_inc);
  for (int q = 0; q < n_inc; ++q) {
    // The single-scattering part and the table's layout from the analytic first order.
    // First order reads smooth interfaces only.
    if (settings.single_scattering_bins && !p.rough_top && !p.unscattered) {
      tables[q] = brdf_table_first_order(stack, opts[q], 6, false);  // its totals are replaced below
    } else {
      tables[q].options = opts[q];
      tables[q].value.assign(2u * K * Mphi, Spectrum(0.0));
      tables[q].stderr_ = tables[q].single = tables[q].multiple = tables[q].single_stderr = tables[q].value;
    }
    z[q] = zeroth_order(stack, mu0[q]);
    t[q].nodes = p.nodes.real;
    value[q].assign(tables[q].value.size(), Spectrum(0.0));
  }
  const BrdfTable& layout = tables[0];
  int modes = 1;
  for (const Medium& m : p.media) modes = std::max(modes, truncation_order(m));

  // 8. phi integrals of cos(m (phi - pi)) over the bins (phi from the light's azimuth; the
  // mirror and ballistic directions are at phi = pi).
  auto phi_integral = [&](int mode, int bin) {
    const double lo = 2.0 * kPi * bin / Mphi, hi = 2.0 * kPi * (bin + 1) / Mphi;
    if (mode == 0) return hi - lo;
    return (std::sin(mode * (hi - kPi)) - std::sin(mode * (lo - kPi))) / mode;
  };
  ModeRadiance L;
  // The size of a mode: its largest outgoing power from an incidence column.
  auto mode_size = [&](const Element& acc) {
    double size = 0.0;
    for (int j : p.nodes.incidences)
      for (int i = 0; i < p.nodes.real; ++i) {
        size = std::max(size, std::abs(acc.Rt(i, j)));
        if (acc.Td.n > 0) size = std::max(size, std::abs(acc.Td(i, j)));
      }
    return size;
  };
  int doublings = 0;
  // The (channel, mode) solutions are independent: they are solved in parallel, a batch of
  // kModeBatch modes of every channel still going at a time, and then taken in order of the mode
  // exactly as a sequential loop would (the stopping rule below, the sums into the bins), so the
  // result does not depend on the threads; a batch's modes past a channel's stop are discarded.
  constexpr int kModeBatch = 4;
  double size0[kChannels] = {0.0, 0.0, 0.0};
  int small[kChannels] = {0, 0, 0};
  bool going[kChannels] = {true, true, true};
  for (int c = 0; c < kChannels; ++c) going[c] = settings.only_channel < 0 || settings.only_channel == c;
  for (int first = 0; first < modes; first += kModeBatch) {
    const int batch = std::min(kModeBatch, modes - first);
    std::vector<std::pair<int, int>> tasks;  // (channel, mode)
    for (int c = 0; c < kChannels; ++c)
      if (going[c])
        for (int mode = first; mode < first + batch; ++mode) tasks.push_back({c, mode});
    if (tasks.empty()) break;
    std::vector<Element> solved(tasks.size()), unscattered(tasks.size());
    std::vector<int> task_doublings(tasks.size(), 0);
    tbb::parallel_for(std::size_t(0), tasks.size(), [&](std::size_t i) {
      solved[i] = solve_stack(p, tasks[i].first, tasks[i].second, &task_doublings[i]);
      // 11. The unscattered solution: for the totals' split (mode 0), and subtracted from the
      // bins unless they hold it (the table mode).
      if (p.unscattered && (tasks[i].second == 0 || !settings.bins_hold_unscattered))
        unscattered[i] = solve_stack(p, tasks[i].first, tasks[i].second, &task_doublings[i], p.unscattered.get());
    });
    for (std::size_t i = 0; i < tasks.size(); ++i) {
      const auto [c, mode] = tasks[i];
      if (!going[c]) continue;
      const Element& acc = solved[i];
      doublings += task_doublings[i];
      if (mode == 0)
        for (int q = 0; q < n_inc; ++q) {
          if (p.unscattered)
            fill_totals_unscattered(p, acc, unscattered[i], c, p.nodes.incidences[q], &t[q]);
          else
            fill_totals(p, acc, z[q], c, p.nodes.incidences[q], &t[q]);
        }
      // The modes fall off with m (multiple scattering smooths the azimuthal dependence, and the
      // phase function's own modes decay as g^m): after two modes below 1e-7 of mode 0 the rest
      // cannot change a bin by more than about that fraction of the largest value, so they are
      // not solved.
      const double size = mode_size(acc);
      if (mode == 0) size0[c] = size;
      small[c] = size <= 1e-7 * size0[c] ? small[c] + 1 : 0;
      const double weight = mode == 0 ? 1.0 : 2.0;
      // What the bins hold: the light that entered (smooth and single-scattering rough tops), or
      // with energy-conserving rough interfaces (11.) the light that scattered (the walk's bins),
      // or in the table mode all but the top's first-order reflection, which the renderer
      // evaluates exactly.
      Matrix binned_R, binned_T;
      const Matrix* source_R = &acc.Rt;
      const Matrix* source_T = &acc.Td;
      if (p.unscattered) {
        binned_R = acc.Rt_direct.n > 0 ? acc.Rt + acc.Rt_direct : acc.Rt;
        binned_T = acc.Td;
        if (!settings.bins_hold_unscattered) {
          const Element& u = unscattered[i];
          binned_R = binned_R - u.Rt;
          if (u.Rt_direct.n > 0) binned_R = binned_R - u.Rt_direct;
          if (binned_T.n > 0) binned_T = binned_T - u.Td;
        } else if (p.rough_top) {
          binned_R = binned_R - rough_interface_element(p, 0, p.size(), mode, true).Rt;
        }
        source_R = &binned_R;
        source_T = &binned_T;
      }
      for (int q = 0; q < n_inc; ++q)
        for (int side = 0; side < (acc.Td.n > 0 ? 2 : 1); ++side) {
          L.build(p, side == 0 ? p.above : p.below, side == 0 ? *source_R : *source_T, p.nodes.incidences[q]);
          for (int k = 0; k < K; ++k) {
            const double mu_part = L.integral(static_cast<double>(k) / K, static_cast<double>(k + 1) / K);
            for (int b = 0; b < Mphi; ++b)
              value[q][layout.bin_index(static_cast<BrdfSide>(side), k, b)][c] +=
                  weight * mu_part * phi_integral(mode, b) / layout.projected_solid_angle(k);
          }
        }
      if (small[c] >= 2) going[c] = false;
    }
  }

  // 9. The delta-M forward peak: the solver counts light scattered into it as unscattered, so
  // its power, (the solver's unscattered exit) - (the exact one) = the true diffuse total minus
  // the bins' mode-0 power, leaves in the mirror (ballistic) direction. It is put in the bin
  // that holds that direction (split between the two bins that meet at phi = pi when M is even,
  // over the whole top ring at normal incidence): the forward peak's width is below a bin's.
  auto add_peak = [&](std::vector<Spectrum>& v, BrdfSide side, double mu, int c, double power) {
    if (mu <= 0.0 || power == 0.0) return;
    const int k = std::min(K - 1, static_cast<int>(mu * K));
    std::vector<int> bins;
    if (mu >= 1.0) {
      for (int b = 0; b < Mphi; ++b) bins.push_back(b);
    } else if (Mphi % 2 == 0) {
      bins = {Mphi / 2 - 1, Mphi / 2};
    } else {
      bins = {Mphi / 2};
    }
    for (int b : bins) v[layout.bin_index(side, k, b)][c] += power / bins.size() / layout.projected_solid_angle(k);
  };
  for (int q = 0; q < n_inc; ++q) {
    t[q].doublings = doublings;
    for (int c = 0; c < kChannels; ++c) {
      double binned_R = 0.0, binned_T = 0.0;
      for (int k = 0; k < K; ++k)
        for (int b = 0; b < Mphi; ++b) {
          binned_R += value[q][layout.bin_index(BrdfSide::Reflect, k, b)][c] * layout.projected_solid_angle(k);
          binned_T += value[q][layout.bin_index(BrdfSide::Transmit, k, b)][c] * layout.projected_solid_angle(k);
        }
      // Under a rough top no light stays unscattered in the solver's incidence node (the top
      // spreads it over the real nodes at once), so there is no peak: the bins hold it all.
      if (p.rough_top) continue;
      if (p.unscattered) {
        // 11. Under a smooth top, what the solver left in the incidence node beyond the
        // unscattered light: the forward peak of the layers above the first rough interface
        // (the light that crossed a rough interface is spread over the real nodes, so nothing
        // is left for transmission). The unscattered light is the unscattered solution's
        // (bins of the light that scattered), or the delta lobes (zeroth_order_above_rough)
        // when the bins hold the rest.
        const double exact = settings.bins_hold_unscattered ? zeroth_order_above_rough(stack, mu0[q]).R_specular[c]
                                                            : t[q].R_specular[c];
        t[q].R_forward_peak[c] = t[q].R_specular[c] + t[q].R_diffuse[c] - exact - binned_R;
        add_peak(value[q], BrdfSide::Reflect, mu0[q], c, t[q].R_forward_peak[c]);
        continue;
      }
      t[q].R_forward_peak[c] = t[q].R_diffuse[c] - binned_R;
      add_peak(value[q], BrdfSide::Reflect, mu0[q], c, t[q].R_forward_peak[c]);
      if (p.transmits) {
        t[q].T_forward_peak[c] = t[q].T_diffuse[c] - binned_T;
        add_peak(value[q], BrdfSide::Transmit, z[q].cos_below, c, t[q].T_forward_peak[c]);
      }
    }
    BrdfTable& table = tables[q];
    for (std::size_t b = 0; b < value[q].size(); ++b) {
      table.value[b] = value[q][b];
      table.multiple[b] = value[q][b] - table.single[b];
      table.stderr_[b] = Spectrum(0.0);
    }
    table.totals.R_specular = {t[q].R_specular, Spectrum(0.0)};
    table.totals.R_diffuse = {t[q].R_diffuse, Spectrum(0.0)};
    table.totals.T_ballistic = {t[q].T_ballistic, Spectrum(0.0)};
    table.totals.T_diffuse = {t[q].T_diffuse, Spectrum(0.0)};
    table.totals.absorbed = {t[q].absorbed, Spectrum(0.0)};
  }
  if (totals) *totals = t;
  return tables;
}

BrdfTable brdf_table_adding_doubling(const LayerStack& stack, const BrdfOptions& options,
                                     const AddingDoublingSettings& settings, AddingDoublingTotals* totals) {
  std::vector<AddingDoublingTotals> t;
  std::vector<BrdfTable> tables = brdf_tables_adding_doubling(stack, options, {options.theta_i_deg}, settings, &t);
  if (totals) *totals = t[0];
  return std::move(tables[0]);
}

namespace {

// 12. The error of a heavily truncated forward peak. Where g^M is near 1, delta-M's truncated
// moments chi'_l = (g^l - g^M)/(1 - g^M) ~ 1 - l/M hardly depend on g: the solution at order N
// scatters with a lobe of width ~1/N where the true one is ~(1 - g) wide, so its error falls
// like N^-p with p at most ~1 (measured: 0.4-1 for g = 0.999), oscillating at oblique
// incidence, and the difference from N/2, d1 = |X_N - X_N/2|, understates it (the error is
// d1 / (2^p - 1): 2.8 d1 at p = 0.44). Richardson's estimate of the order from three solutions,
// p = log2(d0 / d1) with d0 = |X_N/2 - X_N/4| (Richardson 1911; Roache, "Verification and
// Validation in Computational Science and Engineering", 1998, ch. 5), kept at least 1/4 (also
// where d0 <= d1, no convergence seen); the estimate is the largest of d1, d0 and d1/(2^p - 1).
// docs/validation.md gives its record against 256-point solutions and iadpython.
double slow_convergence_error(double d1, double d0) {
  const double p = d0 > d1 && d1 > 0.0 ? std::max(0.25, std::log2(d0 / d1)) : 0.25;
  return std::max({d1, d0, d1 / (std::exp2(p) - 1.0)});
}

}  // namespace

DeltaMTruncation delta_m_truncation(const LayerStack& stack, const AddingDoublingSettings& settings) {
  const Problem p = make_problem(stack, {1.0}, settings, "delta_m_truncation", 0);
  DeltaMTruncation out;
  for (std::size_t k = 0; k < stack.layers.size(); ++k) {
    const Layer& layer = stack.layers[k];
    const int M = truncation_order(p.media[k]);
    for (int c = 0; c < kChannels; ++c) {
      const double sigma_s = layer.sigma_s()[c];
      if (!(sigma_s > 0.0)) continue;
      double forward = 0.0, backward = 0.0;
      for (const PhaseLobe& lobe : layer.lobes) {
        const double w = lobe.sigma_s[c] / sigma_s, g = lobe.g[c];
        (g > 0.0 ? forward : backward) += w * std::pow(std::abs(g), M);
      }
      out.forward = std::max(out.forward, forward);
      out.backward = std::max(out.backward, backward);
    }
  }
  return out;
}

AddingDoublingEstimate adding_doubling_with_error(const LayerStack& stack, double cos_theta_i,
                                                  const AddingDoublingSettings& settings) {
  AddingDoublingEstimate e;
  e.totals = adding_doubling_totals(stack, cos_theta_i, settings);
  AddingDoublingSettings coarse = settings;
  coarse.quadrature_points = std::max(2, settings.quadrature_points / 2);
  const AddingDoublingTotals c = adding_doubling_totals(stack, cos_theta_i, coarse);
  e.forward_truncation = delta_m_truncation(stack, coarse).forward;
  e.extrapolated = e.forward_truncation > kForwardPeakedTruncation;
  AddingDoublingTotals c2;  // N/4 points (12.)
  if (e.extrapolated) {
    AddingDoublingSettings coarser = settings;
    coarser.quadrature_points = std::max(2, settings.quadrature_points / 4);
    c2 = adding_doubling_totals(stack, cos_theta_i, coarser);
  }
  auto diff = [&](Spectrum AddingDoublingTotals::*field) {
    const Spectrum &x = e.totals.*field, &y = c.*field, &z = c2.*field;
    Spectrum d;
    for (int k = 0; k < kChannels; ++k) {
      d[k] = std::abs(x[k] - y[k]);
      if (e.extrapolated) d[k] = slow_convergence_error(d[k], std::abs(y[k] - z[k]));
    }
    return d;
  };
  using T = AddingDoublingTotals;
  for (Spectrum T::*field : {&T::R_specular, &T::R_diffuse, &T::T_ballistic, &T::T_diffuse, &T::absorbed,
                             &T::R_hemispherical, &T::T_hemispherical, &T::absorbed_hemispherical})
    e.error.*field = diff(field);
  e.error.nodes = c.nodes;
  e.error.doublings = c.doublings;
  return e;
}

}  // namespace lamina
