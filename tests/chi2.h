// Chi-square goodness-of-fit harness for sampling routines, in the style of
// pbrt-v4's and Mitsuba's chi2 tests:
//
//   1. draw N samples (directions, or 2D points) with fixed seeds;
//   2. histogram them over a grid of bins (θ×φ on the sphere, around an axis
//      of the caller's choice; any rectangle for 2D points), plus an overflow
//      bin (everything beyond the grid) and a failure bin (samples the routine
//      refused: absorption, a lobe below the horizon, ...);
//   3. expected counts = N × ∫bin pdf, by adaptive Gauss-Legendre cubature of
//      the density in the bin's own coordinates (the sinθ Jacobian included on
//      the sphere); the failure bin expects N × (1 - ∫pdf), ∫pdf given by
//      the caller where known more precisely than the sum over the bins;
//   4. pool the bins whose expected count is < 5 (Mitsuba's rule), compute
//      the statistic and its p-value (regularized upper incomplete gamma), and
//      reject when p < 1 - (1 - α)^(1/T), α = 0.01, T the number of chi-square
//      tests in the program (Šidák correction).
//
// Samples in a bin whose expected count is exactly zero (more than 1e-5 N of
// them) are a failure on their own, whatever the statistic says.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include "luz/math/hash.h"
#include "luz/math/vec.h"

namespace chi2 {

constexpr double kPi = 3.14159265358979323846;
constexpr double kAlpha = 0.01;

// ---------------------------------------------------------------------------
// Random numbers: a pure function of (seed, sample index, dimension), built on
// luz's own hash, so every run draws the same samples.
inline float rand01(uint64_t seed, uint64_t i, uint32_t dim) {
  return luz::to_unit_float(luz::hash_combine(luz::hash_combine(luz::mix64(seed), i), dim));
}
inline luz::Vec2 rand2(uint64_t seed, uint64_t i, uint32_t dim) {
  return {rand01(seed, i, 2 * dim), rand01(seed, i, 2 * dim + 1)};
}

// ---------------------------------------------------------------------------
// Special functions (Numerical Recipes §6.2): regularized incomplete gamma
// P(a, x) by its series for x < a + 1, Q(a, x) = 1 - P by the Lentz continued
// fraction otherwise.
inline double gamma_p_series(double a, double x) {
  double ap = a, term = 1.0 / a, sum = term;
  for (int k = 0; k < 100000; ++k) {
    ap += 1.0;
    term *= x / ap;
    sum += term;
    if (std::fabs(term) < std::fabs(sum) * 1e-17) break;
  }
  return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}
inline double gamma_q_continued_fraction(double a, double x) {
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    double del = d * c;
    h *= del;
    if (std::fabs(del - 1.0) < 1e-16) break;
  }
  return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}
// Regularized upper incomplete gamma Q(a, x) = Γ(a, x) / Γ(a).
inline double gamma_q(double a, double x) {
  if (!(x > 0.0)) return 1.0;
  if (x < a + 1.0) return 1.0 - gamma_p_series(a, x);
  return gamma_q_continued_fraction(a, x);
}
// P(χ²_dof ≥ stat).
inline double chi2_survival(double stat, double dof) { return gamma_q(0.5 * dof, 0.5 * stat); }

// Per-test significance that keeps the family-wise error rate at alpha over
// `tests` independent tests (Šidák).
inline double sidak(double alpha, int tests) { return -std::expm1(std::log1p(-alpha) / tests); }

// Two-sided normal quantile: z with P(|Z| > z) = p.
inline double normal_two_sided_quantile(double p) {
  double lo = 0.0, hi = 40.0;
  for (int k = 0; k < 200; ++k) {
    double mid = 0.5 * (lo + hi);
    if (std::erfc(mid / std::sqrt(2.0)) > p)
      lo = mid;
    else
      hi = mid;
  }
  return 0.5 * (lo + hi);
}

// ---------------------------------------------------------------------------
// The statistic.
struct Result {
  double statistic = 0.0;
  int dof = 0;
  double p_value = 1.0;
  int bins = 0;    // bins with a nonzero expected count
  int pooled = 0;  // of which pooled together (expected < 5)
  double observed_total = 0.0, expected_total = 0.0;
  std::string error;  // samples where the pdf says none can be, etc.

  bool passes(double threshold) const { return error.empty() && p_value >= threshold; }
  std::string summary() const {
    std::ostringstream os;
    os << "chi2 = " << statistic << ", dof = " << dof << ", p = " << p_value << " (bins " << bins << ", pooled "
       << pooled << ", observed " << observed_total << ", expected " << expected_total << ")";
    if (!error.empty()) os << "; " << error;
    return os.str();
  }
};

// Pearson's statistic with Mitsuba's pooling: bins are visited by increasing
// expected count; those below min_expected go to one pool (and the pool keeps
// taking bins until it reaches min_expected), which then counts as one bin.
inline Result chi2_test(const std::vector<double>& observed, const std::vector<double>& expected,
                        double min_expected = 5.0, double zero_bin_tolerance = 1e-5) {
  Result r;
  size_t n = observed.size();
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), size_t(0));
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return expected[a] < expected[b]; });
  r.observed_total = std::accumulate(observed.begin(), observed.end(), 0.0);
  r.expected_total = std::accumulate(expected.begin(), expected.end(), 0.0);
  double pool_obs = 0.0, pool_exp = 0.0, stray = 0.0;
  for (size_t i : order) {
    double o = observed[i], e = expected[i];
    if (!(e > 0.0)) {
      stray += o;
      continue;
    }
    ++r.bins;
    if (e < min_expected || (pool_exp > 0.0 && pool_exp < min_expected)) {
      pool_obs += o;
      pool_exp += e;
      ++r.pooled;
    } else {
      r.statistic += (o - e) * (o - e) / e;
      ++r.dof;
    }
  }
  if (pool_exp > 0.0) {
    r.statistic += (pool_obs - pool_exp) * (pool_obs - pool_exp) / pool_exp;
    ++r.dof;
  }
  if (stray > zero_bin_tolerance * r.observed_total) {
    std::ostringstream os;
    os << stray << " samples fell where the pdf integrates to zero";
    r.error = os.str();
  }
  r.dof -= 1;  // the counts sum to N
  if (r.dof < 1) {
    r.dof = 0;
    r.p_value = 1.0;
    if (r.error.empty() && r.bins > 1) r.error = "fewer than two bins left after pooling";
  } else {
    r.p_value = chi2_survival(r.statistic, r.dof);
  }
  return r;
}

// ---------------------------------------------------------------------------
// Cubature over rectangles: the rectangle is cut into split×split cells, each
// integrated by a 5×5 Gauss-Legendre rule and compared with the same rule on
// its four quarters; a cell is refined while the two disagree by more than
// its share of the tolerance (which halves per level, while a smooth
// integrand's error falls 16-fold and float noise's 4-fold, so those stop at
// once), down to `depth` levels. Along a jump (a triangle's edge seen from a
// point, the horizon in a tilted frame) the error falls only 4-fold per level
// and the depth limit stops it: the residual is ~ cell mass × 2^-depth per
// cut cell. The initial split sets the smallest feature the rule can see
// (a sliver thinner than the node spacing, cell/5, can be missed). The rule
// is open: no node on a cell's edge, so a density that is noisy exactly on a
// bin edge (a cone's rim, float rounding at |p| = 1) does no harm.
namespace detail {
constexpr double kGlNodes[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831, 0.9061798459386640};
constexpr double kGlWeights[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889, 0.4786286704993665,
                                  0.2369268850561891};

template <class F>
double gauss_legendre(F& f, double u0, double u1, double v0, double v1) {
  double hu = 0.5 * (u1 - u0), hv = 0.5 * (v1 - v0), cu = u0 + hu, cv = v0 + hv, s = 0.0;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) s += kGlWeights[i] * kGlWeights[j] * f(cu + hu * kGlNodes[i], cv + hv * kGlNodes[j]);
  return s * hu * hv;
}

template <class F>
double adapt(F& f, double u0, double u1, double v0, double v1, double whole, double tol, int depth) {
  double um = 0.5 * (u0 + u1), vm = 0.5 * (v0 + v1);
  double q[4] = {gauss_legendre(f, u0, um, v0, vm), gauss_legendre(f, um, u1, v0, vm),
                 gauss_legendre(f, u0, um, vm, v1), gauss_legendre(f, um, u1, vm, v1)};
  double sum = q[0] + q[1] + q[2] + q[3];
  if (depth <= 0 || std::fabs(sum - whole) <= tol) return sum;
  return adapt(f, u0, um, v0, vm, q[0], 0.5 * tol, depth - 1) + adapt(f, um, u1, v0, vm, q[1], 0.5 * tol, depth - 1) +
         adapt(f, u0, um, vm, v1, q[2], 0.5 * tol, depth - 1) + adapt(f, um, u1, vm, v1, q[3], 0.5 * tol, depth - 1);
}
}  // namespace detail

// ∫∫ f(u, v) du dv over [u0,u1]×[v0,v1], to about max(abs_tol, rel_tol × |∫|).
template <class F>
double integrate_2d(F&& f, double u0, double u1, double v0, double v1, double rel_tol = 1e-5, double abs_tol = 1e-12,
                    int split = 2, int depth = 6) {
  double du = (u1 - u0) / split, dv = (v1 - v0) / split, estimate = 0.0;
  std::vector<double> whole(size_t(split) * split);
  auto cell = [&](int i, int j, double& a0, double& a1, double& b0, double& b1) {
    a0 = u0 + i * du, a1 = (i + 1 == split) ? u1 : a0 + du;
    b0 = v0 + j * dv, b1 = (j + 1 == split) ? v1 : b0 + dv;
  };
  for (int i = 0; i < split; ++i)
    for (int j = 0; j < split; ++j) {
      double a0, a1, b0, b1;
      cell(i, j, a0, a1, b0, b1);
      estimate += whole[size_t(i) * split + j] = detail::gauss_legendre(f, a0, a1, b0, b1);
    }
  double cell_tol = std::max(abs_tol, rel_tol * std::fabs(estimate)) / (split * split), s = 0.0;
  for (int i = 0; i < split; ++i)
    for (int j = 0; j < split; ++j) {
      double a0, a1, b0, b1;
      cell(i, j, a0, a1, b0, b1);
      s += detail::adapt(f, a0, a1, b0, b1, whole[size_t(i) * split + j], cell_tol, depth);
    }
  return s;
}

// ---------------------------------------------------------------------------
// A histogram over a grid in (u, v), with an overflow bin for u in
// (u1, u_end] and a failure bin.
struct Grid {
  int nu = 10, nv = 20;
  double u0 = 0.0, u1 = 1.0, v0 = 0.0, v1 = 1.0;
  double u_end = 1.0;           // > u1: [u1, u_end]×[v0, v1] is one overflow bin
  double edge_tol = 0.0;        // samples with u ≤ u1 + edge_tol count in the last row (rounding at a sharp edge)
  double quad_rel_tol = 1e-5;   // relative tolerance on each bin's probability
  double quad_abs_tol = 1e-12;  // absolute, for bins where it is ~0
  int quad_split = 2;           // initial cells per dimension and bin
  int quad_depth = 6;
  // ∫pdf over the whole domain, when known better than the sum of the bins
  // (exactly, or by a quadrature that knows the density's shape): the
  // failure bin expects N × (1 - total_mass). Negative: use the bins' sum.
  double total_mass = -1.0;
};

struct Outcome {
  Result result;
  double mass = 0.0;                                // ∫ density over the whole domain (grid + overflow)
  uint64_t samples = 0, failures = 0, outside = 0;  // outside: beyond even the overflow region
  std::vector<double> observed, expected;           // grid row-major (u major), then overflow, then failure
  int nu = 0, nv = 0;

  std::string describe(double threshold) const {
    std::ostringstream os;
    os << result.summary() << "; reject below p = " << threshold << "; ∫pdf = " << mass << ", failed " << failures
       << "/" << samples;
    if (outside) os << ", " << outside << " samples outside the domain";
    // The bins that contribute most to the statistic.
    std::vector<size_t> idx(observed.size());
    std::iota(idx.begin(), idx.end(), size_t(0));
    auto contrib = [&](size_t i) {
      double e = expected[i], o = observed[i];
      return e > 0.0 ? (o - e) * (o - e) / e : (o > 0.0 ? 1e300 : 0.0);
    };
    std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return contrib(a) > contrib(b); });
    os << "\n  worst bins (u, v: observed / expected):";
    for (size_t k = 0; k < std::min<size_t>(6, idx.size()); ++k) {
      size_t i = idx[k];
      os << "\n    ";
      if (i < size_t(nu * nv))
        os << "(" << i / nv << ", " << i % nv << ")";
      else if (i == size_t(nu * nv))
        os << "overflow";
      else
        os << "failed";
      os << ": " << observed[i] << " / " << expected[i];
    }
    return os.str();
  }
};

// Index of the bin holding (u, v): a grid cell (row-major, u major), nu·nv
// for the overflow bin, -1 outside the domain.
inline long grid_bin(const Grid& g, double u, double v) {
  long cells = long(g.nu) * g.nv;
  if (!(u >= g.u0 - g.edge_tol) || !(v >= g.v0) || !(v <= g.v1)) return -1;
  if (u > g.u1 + g.edge_tol) return u <= g.u_end ? cells : -1;
  int iu = std::clamp(int((u - g.u0) / (g.u1 - g.u0) * g.nu), 0, g.nu - 1);
  int iv = std::clamp(int((v - g.v0) / (g.v1 - g.v0) * g.nv), 0, g.nv - 1);
  return long(iu) * g.nv + iv;
}

// The histogram of n samples; sample(i, u, v) -> false when sample i failed.
template <class Sample>
Outcome histogram(const Grid& g, uint64_t n, Sample&& sample) {
  Outcome out;
  out.nu = g.nu;
  out.nv = g.nv;
  size_t cells = size_t(g.nu) * g.nv;
  out.observed.assign(cells + 2, 0.0);
  out.expected.assign(cells + 2, 0.0);
  out.samples = n;
  for (uint64_t i = 0; i < n; ++i) {
    double u, v;
    if (!sample(i, u, v)) {
      ++out.failures;
      out.observed[cells + 1] += 1.0;
      continue;
    }
    long k = grid_bin(g, u, v);
    if (k < 0)
      ++out.outside;
    else
      out.observed[size_t(k)] += 1.0;
  }
  return out;
}

// Expected counts: N × ∫ density over each bin (density in (u, v) coordinates,
// Jacobian included), by the cubature above.
template <class Density>
void integrate_bins(Outcome& out, const Grid& g, Density&& density) {
  size_t cells = size_t(g.nu) * g.nv;
  double du = (g.u1 - g.u0) / g.nu, dv = (g.v1 - g.v0) / g.nv, mass = 0.0, n = double(out.samples);
  for (int iu = 0; iu < g.nu; ++iu)
    for (int iv = 0; iv < g.nv; ++iv) {
      double a0 = g.u0 + iu * du, a1 = iu + 1 == g.nu ? g.u1 : a0 + du;
      double b0 = g.v0 + iv * dv, b1 = iv + 1 == g.nv ? g.v1 : b0 + dv;
      double p = integrate_2d(density, a0, a1, b0, b1, g.quad_rel_tol, g.quad_abs_tol, g.quad_split, g.quad_depth);
      out.expected[size_t(iu) * g.nv + iv] = p * n;
      mass += p;
    }
  out.expected[cells] = 0.0;
  if (g.u_end > g.u1) {
    // The overflow region, cut into as many columns as the grid has.
    double p = 0.0;
    for (int iv = 0; iv < g.nv; ++iv) {
      double b0 = g.v0 + iv * dv, b1 = iv + 1 == g.nv ? g.v1 : b0 + dv;
      p += integrate_2d(density, g.u1, g.u_end, b0, b1, g.quad_rel_tol, g.quad_abs_tol, 2 * g.quad_split, g.quad_depth);
    }
    out.expected[cells] = p * n;
    mass += p;
  }
  out.mass = mass;
}

// The failure bin's expectation, then the statistic.
inline void finish(Outcome& out, const Grid& g) {
  size_t cells = size_t(g.nu) * g.nv;
  out.expected[cells + 1] = std::max(0.0, 1.0 - (g.total_mass >= 0.0 ? g.total_mass : out.mass)) * double(out.samples);
  out.result = chi2_test(out.observed, out.expected);
  if (out.outside && out.result.error.empty()) {
    std::ostringstream os;
    os << out.outside << " samples outside the domain";
    out.result.error = os.str();
  }
}

// The whole test over a grid: histogram, expected counts, statistic.
template <class Sample, class Density>
Outcome run_grid(const Grid& g, uint64_t n, Sample&& sample, Density&& density) {
  Outcome out = histogram(g, n, sample);
  integrate_bins(out, g, density);
  finish(out, g);
  return out;
}

// ---------------------------------------------------------------------------
// Directions: θ×φ bins around `axis`, θ in [0, theta_max] (beyond: overflow),
// φ in [0, 2π). pdf is per unit solid angle, a function of the world direction.
struct D3 {
  double x = 0.0, y = 0.0, z = 0.0;
};
inline double dot(D3 a, D3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline D3 normalized(D3 a) {
  double l = std::sqrt(dot(a, a));
  return {a.x / l, a.y / l, a.z / l};
}
inline D3 to_d3(luz::Vec3 v) { return {v.x, v.y, v.z}; }
inline luz::Vec3 to_vec3(D3 v) { return {float(v.x), float(v.y), float(v.z)}; }

struct DFrame {
  D3 s, t, n;
  explicit DFrame(D3 axis) {
    n = normalized(axis);
    // Duff et al. 2017, in double.
    double sign = std::copysign(1.0, n.z), a = -1.0 / (sign + n.z), b = n.x * n.y * a;
    s = {1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x};
    t = {b, sign + n.y * n.y * a, -n.y};
  }
  D3 to_world(double theta, double phi) const {
    double st = std::sin(theta), ct = std::cos(theta), cp = std::cos(phi), sp = std::sin(phi);
    return {s.x * st * cp + t.x * st * sp + n.x * ct, s.y * st * cp + t.y * st * sp + n.y * ct,
            s.z * st * cp + t.z * st * sp + n.z * ct};
  }
  void to_spherical(D3 w, double& theta, double& phi) const {
    w = normalized(w);
    double x = dot(w, s), y = dot(w, t), z = dot(w, n);
    theta = std::atan2(std::sqrt(x * x + y * y), z);
    phi = std::atan2(y, x);
    if (phi < 0.0) phi += 2.0 * kPi;
    if (phi >= 2.0 * kPi) phi = 0.0;
  }
};

struct SphereGrid {
  int n_theta = 10, n_phi = 20;
  double theta_max = kPi;
  double edge_tol = 0.0;  // radians
  D3 axis{0.0, 0.0, 1.0};
  double quad_rel_tol = 1e-5, quad_abs_tol = 1e-12;
  int quad_split = 2;
  int quad_depth = 6;
  double total_mass = -1.0;  // see Grid
};

// The (θ, φ) grid a SphereGrid stands for.
inline Grid sphere_to_grid(const SphereGrid& sg) {
  Grid g;
  g.nu = sg.n_theta;
  g.nv = sg.n_phi;
  g.u0 = 0.0;
  g.u1 = sg.theta_max;
  g.u_end = sg.theta_max < kPi ? kPi : sg.theta_max;
  g.v0 = 0.0;
  g.v1 = 2.0 * kPi;
  g.edge_tol = sg.edge_tol;
  g.total_mass = sg.total_mass;
  g.quad_rel_tol = sg.quad_rel_tol;
  g.quad_abs_tol = sg.quad_abs_tol;
  g.quad_split = sg.quad_split;
  g.quad_depth = sg.quad_depth;
  return g;
}

// Bin of a direction: a grid cell, n_theta·n_phi for the overflow, -1 outside.
struct SphereBinner {
  Grid grid;
  DFrame frame;
  explicit SphereBinner(const SphereGrid& sg) : grid(sphere_to_grid(sg)), frame(sg.axis) {}
  long bin(D3 w) const {
    double theta, phi;
    frame.to_spherical(w, theta, phi);
    return grid_bin(grid, theta, phi);
  }
};

template <class Sample>
Outcome sphere_histogram(const SphereBinner& b, uint64_t n, Sample&& sample) {
  auto grid_sample = [&](uint64_t i, double& u, double& v) {
    luz::Vec3 w;
    if (!sample(i, w)) return false;
    b.frame.to_spherical(to_d3(w), u, v);
    return true;
  };
  return histogram(b.grid, n, grid_sample);
}

// sample(i, w) -> false when sample i failed (w: a luz::Vec3 direction);
// pdf(D3 w) -> density per unit solid angle.
template <class Sample, class Pdf>
Outcome run_sphere(const SphereGrid& sg, uint64_t n, Sample&& sample, Pdf&& pdf) {
  SphereBinner b(sg);
  Outcome out = sphere_histogram(b, n, sample);
  auto density = [&](double theta, double phi) { return pdf(b.frame.to_world(theta, phi)) * std::sin(theta); };
  integrate_bins(out, b.grid, density);
  finish(out, b.grid);
  return out;
}

// The same with the bins' probabilities computed by the caller (size
// n_theta·n_phi + 1, the last the overflow bin), for densities whose
// integral over a bin is better taken in other coordinates.
template <class Sample>
Outcome run_sphere_expected(const SphereGrid& sg, uint64_t n, Sample&& sample, const std::vector<double>& probability) {
  SphereBinner b(sg);
  Outcome out = sphere_histogram(b, n, sample);
  out.mass = 0.0;
  for (size_t k = 0; k < probability.size() && k + 1 < out.expected.size(); ++k) {
    out.expected[k] = probability[k] * double(n);
    out.mass += probability[k];
  }
  finish(out, b.grid);
  return out;
}

// ---------------------------------------------------------------------------
// Binomial consistency: k successes in n trials against probability p (known
// to ±p_err), two-sided normal approximation at significance `level`.
struct BinomialCheck {
  bool ok = true;
  double z = 0.0, bound = 0.0;
  std::string message;
};
inline BinomialCheck binomial_check(uint64_t k, uint64_t n, double p, double p_err, double level) {
  BinomialCheck c;
  double mean = double(n) * p, sd = std::sqrt(double(n) * std::max(0.0, p * (1.0 - p)));
  double zc = normal_two_sided_quantile(level);
  c.bound = zc * sd + double(n) * p_err + 1.0;  // +1: a count is an integer
  double diff = double(k) - mean;
  c.z = sd > 0.0 ? diff / sd : 0.0;
  c.ok = std::fabs(diff) <= c.bound;
  std::ostringstream os;
  os << "successes " << k << "/" << n << " = " << double(k) / double(n) << ", expected p = " << p << " (z = " << c.z
     << ", allowed |k - np| <= " << c.bound << ")";
  c.message = os.str();
  return c;
}

}  // namespace chi2
