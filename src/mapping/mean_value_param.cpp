#include "mapping/mean_value_param.h"

#include <Eigen/Sparse>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>
#include <limits>

namespace cadinterp::mapping {

bool mean_value_corner_weights(const double* xi, const double* xj, const double* xk, double& wj,
                               double& wk) {
  double e1[3], e2[3];
  for (int a = 0; a < 3; ++a) {
    e1[a] = xj[a] - xi[a];
    e2[a] = xk[a] - xi[a];
  }
  const double l1 = std::sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
  const double l2 = std::sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]);
  if (!(l1 > 0) || !(l2 > 0)) return false;
  const double cosa =
      std::clamp((e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2]) / (l1 * l2), -1.0, 1.0);
  const double half_tan = std::tan(0.5 * std::acos(cosa));
  wj = half_tan / l1;
  wk = half_tan / l2;
  return true;
}

bool mean_value_parametrize(const Surface& s, const Patch& patch,
                            const std::vector<double>& loop_uv, DiskMap& out, std::string& why) {
  out = DiskMap{};
  // The patch's local numbering: cut open along its seams, so a periodic face is a disk.
  out.vertices = patch.local_vertices;
  out.triangles = patch.corner_local;
  const int n = static_cast<int>(out.vertices.size());
  if (out.triangles.size() != 3 * patch.triangles.size() ||
      patch.loop_local.size() != patch.loop.size()) {
    why = "mean-value parametrization: the patch has no local numbering (build_patches)";
    return false;
  }
  out.uv.assign(2 * std::size_t(n), 0.0);

  // Unknowns: the interior vertices, numbered in local order.
  std::vector<int> unknown(static_cast<std::size_t>(n), -1);
  std::vector<char> fixed(static_cast<std::size_t>(n), 0);
  for (std::size_t i = 0; i < patch.loop.size(); ++i) {
    const int l = patch.loop_local[i];
    fixed[static_cast<std::size_t>(l)] = 1;
    out.uv[2 * std::size_t(l)] = loop_uv[2 * i];
    out.uv[2 * std::size_t(l) + 1] = loop_uv[2 * i + 1];
  }
  int m = 0;
  for (int i = 0; i < n; ++i)
    if (!fixed[static_cast<std::size_t>(i)]) unknown[static_cast<std::size_t>(i)] = m++;
  if (m == 0) return true;

  // Mean-value weights w_ij = (tan(a/2) + tan(b/2)) / |x_j - x_i|, a and b the angles at i of
  // the two triangles along edge ij (Floater 2003, Eq. 5.1); summed triangle by triangle.
  std::vector<Eigen::Triplet<double>> trip;
  std::vector<double> diag(static_cast<std::size_t>(m), 0.0);
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(m, 2);
  const std::size_t T = out.triangles.size() / 3;
  for (std::size_t t = 0; t < T; ++t) {
    for (int c = 0; c < 3; ++c) {
      const int i = out.triangles[3 * t + std::size_t(c)];
      const int ui = unknown[static_cast<std::size_t>(i)];
      if (ui < 0) continue;
      const int j = out.triangles[3 * t + std::size_t((c + 1) % 3)];
      const int k = out.triangles[3 * t + std::size_t((c + 2) % 3)];
      const double* xi = s.position(out.vertices[static_cast<std::size_t>(i)]);
      const double* xj = s.position(out.vertices[static_cast<std::size_t>(j)]);
      const double* xk = s.position(out.vertices[static_cast<std::size_t>(k)]);
      double wj, wk;
      if (!mean_value_corner_weights(xi, xj, xk, wj, wk)) {
        why = "degenerate triangle in a patch (zero-length edge)";
        return false;
      }
      for (const auto& [other, w] : {std::make_pair(j, wj), std::make_pair(k, wk)}) {
        diag[static_cast<std::size_t>(ui)] += w;
        const int uo = unknown[static_cast<std::size_t>(other)];
        if (uo >= 0) {
          trip.emplace_back(ui, uo, -w);
        } else {
          rhs(ui, 0) += w * out.uv[2 * std::size_t(other)];
          rhs(ui, 1) += w * out.uv[2 * std::size_t(other) + 1];
        }
      }
    }
  }
  for (int i = 0; i < m; ++i) trip.emplace_back(i, i, diag[static_cast<std::size_t>(i)]);
  Eigen::SparseMatrix<double> A(m, m);
  A.setFromTriplets(trip.begin(), trip.end());
  Eigen::SparseLU<Eigen::SparseMatrix<double>> lu;
  lu.compute(A);
  if (lu.info() != Eigen::Success) {
    why = "mean-value parametrization: sparse factorization failed";
    return false;
  }
  const Eigen::MatrixXd x = lu.solve(rhs);
  for (int i = 0; i < n; ++i) {
    const int ui = unknown[static_cast<std::size_t>(i)];
    if (ui < 0) continue;
    out.uv[2 * std::size_t(i)] = x(ui, 0);
    out.uv[2 * std::size_t(i) + 1] = x(ui, 1);
    if (!std::isfinite(x(ui, 0)) || !std::isfinite(x(ui, 1))) {
      why = "mean-value parametrization: non-finite solution";
      return false;
    }
  }
  return true;
}

DiskLocator::DiskLocator(const DiskMap& m) : m_(m) {
  const std::size_t T = m.triangles.size() / 3;
  n_ = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(T) / 2.0)));
  std::vector<std::vector<int>> cells(static_cast<std::size_t>(n_) * std::size_t(n_));
  for (std::size_t t = 0; t < T; ++t) {
    double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
    for (int c = 0; c < 3; ++c)
      for (int a = 0; a < 2; ++a) {
        const double x =
            m.uv[2 * std::size_t(m.triangles[3 * t + std::size_t(c)]) + std::size_t(a)];
        lo[a] = std::min(lo[a], x);
        hi[a] = std::max(hi[a], x);
      }
    for (int j = cell(lo[1]); j <= cell(hi[1]); ++j)
      for (int i = cell(lo[0]); i <= cell(hi[0]); ++i)
        cells[static_cast<std::size_t>(j * n_ + i)].push_back(static_cast<int>(t));
  }
  start_.push_back(0);
  for (const auto& c : cells) {
    items_.insert(items_.end(), c.begin(), c.end());
    start_.push_back(static_cast<int>(items_.size()));
  }
}

int DiskLocator::cell(double x) const {
  const int c = static_cast<int>(std::floor((x + 1.0) * 0.5 * n_));
  return std::clamp(c, 0, n_ - 1);
}

void DiskLocator::weights(int t, double u, double v, double w[3]) const {
  const double* p[3];
  for (int c = 0; c < 3; ++c)
    p[c] = &m_.uv[2 * std::size_t(m_.triangles[3 * std::size_t(t) + std::size_t(c)])];
  const double det =
      (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
  if (det == 0) {
    w[0] = 1;
    w[1] = w[2] = -1;  // never chosen over a real triangle
    return;
  }
  w[1] = ((u - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (v - p[0][1])) / det;
  w[2] = ((p[1][0] - p[0][0]) * (v - p[0][1]) - (u - p[0][0]) * (p[1][1] - p[0][1])) / det;
  w[0] = 1 - w[1] - w[2];
}

void DiskLocator::locate(double u, double v, int& triangle, double w[3]) const {
  double best = -std::numeric_limits<double>::infinity();
  triangle = -1;
  auto consider = [&](int t) {
    double q[3];
    weights(t, u, v, q);
    const double worst = std::min({q[0], q[1], q[2]});
    if (worst > best) {
      best = worst;
      triangle = t;
      std::copy(q, q + 3, w);
    }
  };
  const int c = cell(v) * n_ + cell(u);
  for (int i = start_[static_cast<std::size_t>(c)]; i < start_[static_cast<std::size_t>(c) + 1];
       ++i) {
    consider(items_[static_cast<std::size_t>(i)]);
    if (best >= 0) break;
  }
  if (best < -1e-9) {  // outside the cell's triangles: search them all
    const int T = static_cast<int>(m_.triangles.size() / 3);
    for (int t = 0; t < T && best < 0; ++t) consider(t);
  }
  double sum = 0;
  for (int k = 0; k < 3; ++k) sum += (w[k] = std::max(0.0, w[k]));
  for (int k = 0; k < 3; ++k) w[k] /= sum;
}

}  // namespace cadinterp::mapping
