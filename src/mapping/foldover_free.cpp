#include "mapping/foldover_free.h"

#include <Eigen/Dense>
#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <deque>

namespace cadinterp::mapping {

namespace {

constexpr double kSigmaFloor = 0.5;

using Eigen::VectorXd;

// chi(D) = (D + sqrt(eps^2 + D^2)) / 2: a smooth positive stand-in for max(D, 0).
double chi(double d, double eps) { return 0.5 * (d + std::sqrt(eps * eps + d * d)); }

// Dimension-generic pieces: D = 3 for tets, 2 for planar triangles.
template <int D>
using Mat = Eigen::Matrix<double, D, D>;

// Edge matrix of element q (D + 1 indices) with positions x (#V by D): columns x_k - x_0.
template <int D>
Mat<D> edges(const std::vector<double>& x, const std::uint32_t* q) {
  Mat<D> m;
  for (int i = 0; i < D; ++i)
    for (int a = 0; a < D; ++a)
      m(a, i) =
          x[D * std::size_t(q[i + 1]) + std::size_t(a)] - x[D * std::size_t(q[0]) + std::size_t(a)];
  return m;
}

// c^(-2/D), the shape term's factor, for c > 0. For tets, y = c^(-1/3) from a bit-level first
// guess (the exponent divided by -3, a few percent off) and Newton's iteration
// y <- y (4 - c y^3) / 3, which needs no division and doubles the digits each step (four steps
// reach rounding). This is the untangler's innermost call, where libm's pow and cbrt (with frexp
// and scalbn) cost a fifth and a quarter of its time; without them mapping_bench runs 15 % more
// tet evaluations per second (docs/mapping-decisions.md, "Energy without `pow`").
template <int D>
double inverse_power_p(double c, double inverse_c);
template <>
inline double inverse_power_p<3>(double c, double) {
  if (!(c > 1e-280 && c < 1e280)) return 1.0 / (std::cbrt(c) * std::cbrt(c));
  std::uint64_t bits;
  std::memcpy(&bits, &c, sizeof bits);
  bits = 0x553EF0FF289DD796ull - bits / 3;
  double y;
  std::memcpy(&y, &bits, sizeof y);
  const double third = c / 3;
  for (int i = 0; i < 4; ++i) y *= 4.0 / 3.0 - third * (y * y * y);
  return y * y;
}
template <>
inline double inverse_power_p<2>(double, double inverse_c) {
  return inverse_c;
}

// a b, spelled out (b also a transpose expression): Eigen's fixed-size products were not inlined
// here and took a quarter of the untangler's time.
template <int D, class B>
inline Mat<D> product(const Mat<D>& a, const B& b) {
  Mat<D> m;
  for (int i = 0; i < D; ++i)
    for (int k = 0; k < D; ++k) {
      double sum = 0;
      for (int j = 0; j < D; ++j) sum += a(i, j) * b(j, k);
      m(i, k) = sum;
    }
  return m;
}

// d(det J)/dJ, the cofactor matrix.
inline Mat<3> cofactor(const Mat<3>& j) {
  Mat<3> c;
  c.col(0) = j.col(1).cross(j.col(2));
  c.col(1) = j.col(2).cross(j.col(0));
  c.col(2) = j.col(0).cross(j.col(1));
  return c;
}
inline Mat<2> cofactor(const Mat<2>& j) {
  Mat<2> c;
  c << j(1, 1), -j(1, 0), -j(0, 1), j(0, 0);
  return c;
}

// The energy over the elements touching a free vertex, as a function of the free vertices only.
// `reference[e]` is element e's reference edge matrix (positive determinant).
template <int D>
class Energy {
 public:
  Energy(const std::vector<Mat<D>>& reference, const std::vector<std::uint32_t>& elements,
         const std::vector<char>& free_vertex, std::vector<double>& x)
      : elements_(elements), x_(x), unknown_(x.size() / D, -1) {
    for (std::size_t v = 0; v < unknown_.size(); ++v)
      if (free_vertex[v]) {
        unknown_[v] = static_cast<int>(free_.size());
        free_.push_back(static_cast<std::uint32_t>(v));
      }
    const std::size_t E = elements.size() / (D + 1);
    double ref_volume = 0, volume = 0;
    for (std::size_t e = 0; e < E; ++e) {
      const std::uint32_t* q = &elements[(D + 1) * e];
      bool touches = false;
      for (int i = 0; i <= D; ++i) touches = touches || unknown_[q[i]] >= 0;
      if (!touches) continue;
      const double det = reference[e].determinant();
      if (!(det > 0)) continue;  // a flat reference element has no shape to keep
      active_.push_back(static_cast<std::uint32_t>(e));
      inverse_.push_back(reference[e].inverse());
      weight_.push_back(det);
      ref_volume += det;
      volume += edges<D>(x, q).determinant();
    }
    // The region's signed volume is fixed by its boundary (the sum of signed volumes over
    // elements that tile a region depends only on the region's boundary), so the reference is
    // scaled to it: the volume term then asks for det J = 1 on average, not for the
    // reference's own volume.
    const double ratio = ref_volume > 0 && volume > 0 ? volume / ref_volume : 1.0;
    const double scale = std::pow(ratio, -1.0 / D);
    for (auto& m : inverse_) m *= scale;
    length_ = active_.empty() ? 1.0 : std::pow(volume / double(active_.size()), 1.0 / D);
  }

  std::size_t unknowns() const { return D * free_.size(); }
  std::size_t free_vertices() const { return free_.size(); }
  double length() const { return length_; }
  int evaluations() const { return evaluations_; }

  VectorXd get() const {
    VectorXd z(unknowns());
    for (std::size_t i = 0; i < free_.size(); ++i)
      for (std::size_t a = 0; a < D; ++a) z[Eigen::Index(D * i + a)] = x_[D * free_[i] + a];
    return z;
  }
  void set(const VectorXd& z) {
    for (std::size_t i = 0; i < free_.size(); ++i)
      for (std::size_t a = 0; a < D; ++a) x_[D * free_[i] + a] = z[Eigen::Index(D * i + a)];
  }

  // F(z) and its gradient; `min_det` gets the smallest det J.
  double operator()(const VectorXd& z, double eps, VectorXd* grad, double* min_det) {
    ++evaluations_;
    set(z);
    if (grad) grad->setZero(Eigen::Index(unknowns()));
    constexpr double p = 2.0 / D;  // the shape term's exponent: scale-invariant
    double energy = 0, smallest = HUGE_VAL;
    for (std::size_t k = 0; k < active_.size(); ++k) {
      const std::uint32_t* q = &elements_[(D + 1) * std::size_t(active_[k])];
      const Mat<D> j = product<D>(edges<D>(x_, q), inverse_[k]);
      const double d = j.determinant();
      smallest = std::min(smallest, d);
      const double root = std::sqrt(eps * eps + d * d);
      const double c = 0.5 * (d + root);  // chi(D)
      const double ic = 1 / c;
      const double tr = j.squaredNorm();
      const double icp = inverse_power_p<D>(c, ic);  // chi^(-2/D)
      energy += weight_[k] * (0.5 / D * tr * icp + 0.25 * (d * d + 1) * ic);
      if (!grad) continue;
      const double dchi = c / root;  // chi'(D)
      const Mat<D> g_j = (icp / D) * j + (-p / (2 * D) * tr * dchi * icp * ic + 0.5 * d * ic -
                                          0.25 * (d * d + 1) * dchi * ic * ic) *
                                             cofactor(j);
      // J = E S^-1 (E the edge matrix), so dF/dE = dF/dJ S^-T.
      const Mat<D> g_e = product<D>(Mat<D>(weight_[k] * g_j), inverse_[k].transpose());
      for (int i = 0; i < D; ++i) add(*grad, q[i + 1], g_e.col(i));
      add(*grad, q[0], -g_e.rowwise().sum());
    }
    if (min_det) *min_det = smallest;
    return energy;
  }

 private:
  void add(VectorXd& g, std::uint32_t v, const Eigen::Matrix<double, D, 1>& value) const {
    const int u = unknown_[v];
    if (u < 0) return;
    g.template segment<D>(D * u) += value;
  }

  const std::vector<std::uint32_t>& elements_;
  std::vector<double>& x_;
  std::vector<int> unknown_;
  std::vector<std::uint32_t> free_, active_;
  std::vector<Mat<D>> inverse_;
  std::vector<double> weight_;
  double length_ = 1;
  int evaluations_ = 0;
};

// Limited-memory BFGS (two-loop recursion, Nocedal and Wright Alg. 7.4) with an Armijo
// backtracking line search; z is left at the last accepted point.
template <int D>
void minimise(Energy<D>& energy, VectorXd& z, double eps, int iterations, int max_evaluations) {
  constexpr std::size_t kMemory = 8;
  std::deque<VectorXd> s_list, y_list;
  VectorXd g, g_new;
  double f = energy(z, eps, &g, nullptr);
  // A first (or restarted) step along -g moves no vertex by more than a tenth of a typical edge.
  auto gradient_step = [&](VectorXd& d) {
    d = -g;
    const double m = d.template lpNorm<Eigen::Infinity>();
    if (m > 0) d *= 0.1 * energy.length() / m;
  };
  for (int it = 0; it < iterations && energy.evaluations() < max_evaluations; ++it) {
    // Two-loop recursion: d = -H g.
    VectorXd d = -g;
    std::vector<double> alpha(s_list.size());
    for (std::size_t i = s_list.size(); i-- > 0;) {
      alpha[i] = s_list[i].dot(d) / y_list[i].dot(s_list[i]);
      d -= alpha[i] * y_list[i];
    }
    if (s_list.empty()) {
      gradient_step(d);
    } else {
      d *= s_list.back().dot(y_list.back()) / y_list.back().squaredNorm();
      for (std::size_t i = 0; i < s_list.size(); ++i) {
        const double beta = y_list[i].dot(d) / y_list[i].dot(s_list[i]);
        d += (alpha[i] - beta) * s_list[i];
      }
    }
    double slope = g.dot(d);
    if (!(slope < 0)) {  // not a descent direction: restart from the gradient
      s_list.clear();
      y_list.clear();
      gradient_step(d);
      slope = g.dot(d);
      if (!(slope < 0)) break;
    }
    double step = 1, f_new = 0;
    VectorXd z_new;
    bool accepted = false;
    for (int halving = 0; halving < 40 && !accepted; ++halving, step *= 0.5) {
      z_new = z + step * d;
      f_new = energy(z_new, eps, &g_new, nullptr);
      accepted = std::isfinite(f_new) && f_new <= f + 1e-4 * step * slope;
    }
    if (!accepted) break;
    VectorXd s = z_new - z, y = g_new - g;
    const bool converged = f - f_new <= 1e-10 * std::fabs(f);
    z = std::move(z_new);
    g.swap(g_new);
    f = f_new;
    if (converged) break;
    if (s.dot(y) > 1e-12 * s.norm() * y.norm()) {
      s_list.push_back(std::move(s));
      y_list.push_back(std::move(y));
      if (s_list.size() > kMemory) {
        s_list.pop_front();
        y_list.pop_front();
      }
    }
  }
  energy.set(z);
}

// Elements whose signed measure (det of the edge matrix: 6 V, or 2 A) is at most `min_measure`.
template <int D>
std::size_t count_inverted(const std::vector<double>& x, const std::vector<std::uint32_t>& elements,
                           double min_measure, const std::vector<std::uint32_t>* only = nullptr) {
  std::size_t n = 0;
  auto bad = [&](std::size_t e) {
    return !(edges<D>(x, &elements[(D + 1) * e]).determinant() > min_measure);
  };
  if (only) {
    for (std::uint32_t e : *only) n += bad(e) ? 1 : 0;
  } else {
    for (std::size_t e = 0; e < elements.size() / (D + 1); ++e) n += bad(e) ? 1 : 0;
  }
  return n;
}

// One attempt with the given free vertices: the eps schedule of Garanzha et al. (2021, §3.2),
// with a floor of 0.5 on sigma where the paper has 0.1. The energy sums over every active
// element, most of them valid, so one minimisation rarely gains 10 % of it and sigma sits at its
// floor. The higher floor keeps the steps large enough to make progress: on an OpenCASCADE press
// pair it leaves a quarter of the inverted tets that 0.1 leaves, in a third of the evaluations
// (docs/mapping-decisions.md, "Interior and untangling"). Leaves x at the state with the fewest
// inverted elements.
template <int D>
void attempt(Energy<D>& energy, const std::vector<double>& x,
             const std::vector<std::uint32_t>& elements, double min_measure,
             const FoldoverFreeOptions& options) {
  VectorXd z = energy.get();
  VectorXd best = z;
  std::size_t best_inverted = count_inverted<D>(x, elements, min_measure);
  double min_det = 0;
  energy(z, 1.0, nullptr, &min_det);
  double eps = std::sqrt(1e-12 + 0.04 * std::pow(std::min(min_det, 0.0), 2));
  double e_prev = energy(z, eps, nullptr, nullptr);
  int stalled = 0;
  const int budget = options.max_evaluations > 0 ? options.max_evaluations : INT_MAX;
  for (int k = 0; k < options.outer_iterations && best_inverted > 0; ++k) {
    if (energy.evaluations() >= budget) break;
    minimise(energy, z, eps, options.inner_iterations, budget);
    const double e = energy(z, eps, nullptr, &min_det);
    const std::size_t inverted = count_inverted<D>(x, elements, min_measure);
    if (inverted < best_inverted) {
      best_inverted = inverted;
      best = z;
      stalled = 0;
    } else if (++stalled == options.stall_iterations) {
      break;  // elements that no interior placement untangles (a boundary face folded over)
    }
    // Lower eps by how much the last minimisation gained: sigma near 1 (a large gain) keeps mu
    // near 0 and eps small; a stalled minimisation (sigma = 0.1) keeps eps near chi(D_min).
    const double sigma = std::max(1 - e / e_prev, kSigmaFloor);
    const double mu = (1 - sigma) * chi(min_det, eps);
    eps = min_det < mu ? 2 * std::sqrt(mu * (mu - min_det)) : 1e-13;
    e_prev = energy(z, eps, nullptr, nullptr);
  }
  energy.set(best);
}

template <int D>
FoldoverFreeResult untangle(const std::vector<Mat<D>>& reference,
                            const std::vector<std::uint32_t>& elements,
                            const std::vector<char>& fixed, double min_measure,
                            std::vector<double>& x, const FoldoverFreeOptions& options) {
  FoldoverFreeResult r;
  const std::size_t V = x.size() / D, E = elements.size() / (D + 1);
  r.inverted_before = r.inverted_after = count_inverted<D>(x, elements, min_measure);
  if (r.inverted_before == 0) return r;
  // Free: vertices not fixed within `rings` vertex rings of an inverted element (all for -1).
  std::vector<char> free_vertex(V, 0);
  if (options.rings < 0) {
    for (std::size_t v = 0; v < V; ++v) free_vertex[v] = fixed[v] ? 0 : 1;
  } else {
    std::vector<std::vector<std::uint32_t>> next_to(V);
    for (std::size_t e = 0; e < E; ++e)
      for (std::size_t i = 0; i <= D; ++i)
        for (std::size_t j = 0; j <= D; ++j)
          if (i != j) next_to[elements[(D + 1) * e + i]].push_back(elements[(D + 1) * e + j]);
    std::vector<int> ring(V, -1);
    std::vector<std::uint32_t> front;
    for (std::size_t e = 0; e < E; ++e)
      if (!(edges<D>(x, &elements[(D + 1) * e]).determinant() > min_measure))
        for (std::size_t i = 0; i <= D; ++i) {
          const std::uint32_t v = elements[(D + 1) * e + i];
          if (ring[v] < 0) {
            ring[v] = 0;
            front.push_back(v);
          }
        }
    for (int k = 1; k <= options.rings; ++k) {
      std::vector<std::uint32_t> grown;
      for (std::uint32_t v : front)
        for (std::uint32_t u : next_to[v])
          if (ring[u] < 0) {
            ring[u] = k;
            grown.push_back(u);
          }
      front.swap(grown);
    }
    for (std::size_t v = 0; v < V; ++v) free_vertex[v] = !fixed[v] && ring[v] >= 0 ? 1 : 0;
  }
  std::vector<double> work = x;
  Energy<D> energy(reference, elements, free_vertex, work);
  r.free_vertices = energy.free_vertices();
  if (energy.free_vertices() > 0) attempt(energy, work, elements, min_measure, options);
  r.evaluations = energy.evaluations();
  const std::size_t after = count_inverted<D>(work, elements, min_measure);
  if (after < r.inverted_after) {
    r.inverted_after = after;
    x = std::move(work);
  }
  return r;
}

// Each reference tet's edge matrix.
std::vector<Mat<3>> tet_shapes(const std::vector<double>& reference,
                               const std::vector<std::uint32_t>& tets) {
  std::vector<Mat<3>> shapes(tets.size() / 4);
  for (std::size_t t = 0; t < shapes.size(); ++t) shapes[t] = edges<3>(reference, &tets[4 * t]);
  return shapes;
}

}  // namespace

FoldoverFreeResult untangle_foldover_free(const std::vector<double>& reference,
                                          const std::vector<std::uint32_t>& tets,
                                          const std::vector<char>& fixed, double min_six_volume,
                                          std::vector<double>& x,
                                          const FoldoverFreeOptions& options) {
  return untangle<3>(tet_shapes(reference, tets), tets, fixed, min_six_volume, x, options);
}

double foldover_free_energy(const std::vector<double>& reference,
                            const std::vector<std::uint32_t>& tets, const std::vector<char>& fixed,
                            const std::vector<double>& x, double eps,
                            std::vector<double>* gradient) {
  const std::vector<Mat<3>> shapes = tet_shapes(reference, tets);
  std::vector<char> free_vertex(fixed.size());
  for (std::size_t v = 0; v < fixed.size(); ++v) free_vertex[v] = fixed[v] ? 0 : 1;
  std::vector<double> work = x;
  Energy<3> energy(shapes, tets, free_vertex, work);
  VectorXd g;
  const double f = energy(energy.get(), eps, gradient ? &g : nullptr, nullptr);
  if (gradient) {
    gradient->assign(x.size(), 0.0);
    std::size_t i = 0;
    for (std::size_t v = 0; v < free_vertex.size(); ++v)
      if (free_vertex[v])
        for (std::size_t a = 0; a < 3; ++a, ++i) (*gradient)[3 * v + a] = g[Eigen::Index(i)];
  }
  return f;
}

FoldoverFreeResult untangle_foldover_free_planar(const std::vector<double>& reference,
                                                 const std::vector<std::uint32_t>& triangles,
                                                 const std::vector<char>& fixed,
                                                 double min_two_area, std::vector<double>& x,
                                                 const FoldoverFreeOptions& options) {
  // Each reference triangle in its own plane: edge a-b along the first axis.
  std::vector<Mat<2>> shapes(triangles.size() / 3);
  for (std::size_t t = 0; t < shapes.size(); ++t) {
    const Eigen::Vector3d a(&reference[3 * std::size_t(triangles[3 * t])]),
        b(&reference[3 * std::size_t(triangles[3 * t + 1])]),
        c(&reference[3 * std::size_t(triangles[3 * t + 2])]);
    const Eigen::Vector3d e1 = b - a, e2 = c - a;
    const double l1 = e1.norm();
    Mat<2> m = Mat<2>::Zero();
    if (l1 > 0) {
      const double along = e2.dot(e1) / l1;
      m << l1, along, 0, std::sqrt(std::max(0.0, e2.squaredNorm() - along * along));
    }
    shapes[t] = m;
  }
  return untangle<2>(shapes, triangles, fixed, min_two_area, x, options);
}

}  // namespace cadinterp::mapping
