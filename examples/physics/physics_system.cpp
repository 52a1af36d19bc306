// The sparse FE system: a pattern from the node graph, direct scatter of element matrices and
// Dirichlet constraints that keep the matrix symmetric positive definite.
#include <algorithm>
#include <climits>
#include <string>

#include "physics_internal.h"

namespace cadinterp::physics::detail {

System::System(const NodeGraph& graph, int components) : graph_(graph), c_(components) {
  const std::size_t n = graph.start.size() - 1;
  const std::size_t dofs = n * static_cast<std::size_t>(c_);
  const std::size_t nnz = graph.neighbors.size() * static_cast<std::size_t>(c_ * c_);
  if (dofs >= static_cast<std::size_t>(INT_MAX) || nnz >= static_cast<std::size_t>(INT_MAX)) {
    throw Error("physics: system too large (" + std::to_string(dofs) + " unknowns, " +
                std::to_string(nnz) + " nonzeros; the sparse indices are 32-bit)");
  }
  K.resize(static_cast<Eigen::Index>(dofs), static_cast<Eigen::Index>(dofs));
  K.resizeNonZeros(static_cast<Eigen::Index>(nnz));
  int* outer = K.outerIndexPtr();
  int* inner = K.innerIndexPtr();
  double* values = K.valuePtr();
  std::fill(values, values + nnz, 0.0);
  // Column (node b, comp j) holds every neighbour m of b with all components, in order: its
  // start is c^2 start[b] + j c deg(b), so position() needs no per-column table.
  for (std::size_t b = 0; b < n; ++b) {
    const std::size_t deg = graph.start[b + 1] - graph.start[b];
    for (int j = 0; j < c_; ++j) {
      std::size_t p = static_cast<std::size_t>(c_ * c_) * graph.start[b] +
                      static_cast<std::size_t>(j * c_) * deg;
      outer[b * c_ + j] = static_cast<int>(p);
      for (std::size_t k = graph.start[b]; k < graph.start[b + 1]; ++k) {
        for (int i = 0; i < c_; ++i) inner[p++] = static_cast<int>(graph.neighbors[k] * c_ + i);
      }
    }
  }
  outer[dofs] = static_cast<int>(nnz);
  f = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(dofs));
}

std::size_t System::position(std::uint32_t a, int i, std::uint32_t b, int j) const {
  const std::uint32_t* first = graph_.neighbors.data() + graph_.start[b];
  const std::uint32_t* last = graph_.neighbors.data() + graph_.start[b + 1];
  const auto k = static_cast<std::size_t>(std::lower_bound(first, last, a) - first);
  return static_cast<std::size_t>(K.outerIndexPtr()[b * c_ + j]) + k * c_ + i;
}

void System::add_element(const std::uint32_t* element_nodes, int n, const double* Ke) {
  double* values = K.valuePtr();
  const int* outer = K.outerIndexPtr();
  const int stride = n * c_;
  for (int lb = 0; lb < n; ++lb) {
    const std::uint32_t b = element_nodes[lb];
    const std::uint32_t* first = graph_.neighbors.data() + graph_.start[b];
    const std::uint32_t* last = graph_.neighbors.data() + graph_.start[b + 1];
    for (int la = 0; la < n; ++la) {
      const auto k =
          static_cast<std::size_t>(std::lower_bound(first, last, element_nodes[la]) - first);
      for (int j = 0; j < c_; ++j) {
        double* column = values + outer[b * c_ + j] + k * c_;
        const double* ke = Ke + (la * c_) * stride + lb * c_ + j;
        for (int i = 0; i < c_; ++i) column[i] += ke[i * stride];
      }
    }
  }
}

void System::constrain(const std::vector<std::uint8_t>& is_fixed, const Eigen::VectorXd& g) {
  const int* outer = K.outerIndexPtr();
  const int* inner = K.innerIndexPtr();
  double* values = K.valuePtr();
  fixed_dofs_.clear();
  for (std::size_t i = 0; i < is_fixed.size(); ++i) {
    if (is_fixed[i]) fixed_dofs_.push_back(i);
  }
  // Keep the original rows (= columns, by symmetry) and loads for the reactions.
  fixed_rows_.assign(fixed_dofs_.size(), {});
  fixed_rhs_.resize(fixed_dofs_.size());
  for (std::size_t k = 0; k < fixed_dofs_.size(); ++k) {
    const std::size_t col = fixed_dofs_[k];
    for (int p = outer[col]; p < outer[col + 1]; ++p) {
      if (values[p] != 0.0) fixed_rows_[k].emplace_back(inner[p], values[p]);
    }
    fixed_rhs_[k] = f[static_cast<Eigen::Index>(col)];
  }
  // Move the known values to the right-hand side of the free rows (f_r -= K_ri g_i).
  for (std::size_t k = 0; k < fixed_dofs_.size(); ++k) {
    const double gi = g[static_cast<Eigen::Index>(fixed_dofs_[k])];
    if (gi == 0.0) continue;
    for (const auto& [row, v] : fixed_rows_[k]) f[row] -= v * gi;
  }
  // Decouple: zero row and column i except the diagonal; K_ii u_i = K_ii g_i keeps the scale.
  const auto c = static_cast<std::size_t>(c_);
  for (std::size_t k = 0; k < fixed_dofs_.size(); ++k) {
    const std::size_t col = fixed_dofs_[k];
    double diagonal = 0.0;
    for (int p = outer[col]; p < outer[col + 1]; ++p) {
      const auto row = static_cast<std::size_t>(inner[p]);
      if (row == col) {
        diagonal = values[p];
        continue;
      }
      values[p] = 0.0;
      values[position(static_cast<std::uint32_t>(col / c), static_cast<int>(col % c),
                      static_cast<std::uint32_t>(row / c), static_cast<int>(row % c))] = 0.0;
    }
    f[static_cast<Eigen::Index>(col)] = diagonal * g[static_cast<Eigen::Index>(col)];
  }
}

Eigen::VectorXd System::constrained_residual(const Eigen::VectorXd& u) const {
  Eigen::VectorXd r(static_cast<Eigen::Index>(fixed_dofs_.size()));
  for (std::size_t k = 0; k < fixed_dofs_.size(); ++k) {
    double s = -fixed_rhs_[k];
    for (const auto& [row, v] : fixed_rows_[k]) s += v * u[row];
    r[static_cast<Eigen::Index>(k)] = s;
  }
  return r;
}

}  // namespace cadinterp::physics::detail
