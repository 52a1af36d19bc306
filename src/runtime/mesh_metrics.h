// Derived quantities of an evaluated tet mesh (volume, mass, centroid, inertia, surface area,
// frontal area) and their vector-Jacobian products with respect to the vertex positions, so the
// runtime can chain them with dV/dx (the per-parameter derivative of the blended positions) and
// hand an optimizer d(metric)/dx.
//
// Conventions
// - A tet (a, b, c, d) is positively oriented when det[b-a, c-a, d-a] > 0. Volumes are *signed*
//   and summed without |.|: on a consistently, positively oriented mesh this is exactly the
//   volume of the solid; the signed sum is a polynomial (so its gradient exists everywhere, where
//   |.| has a kink at flat tets); and a tet inverted by interpolation subtracts from the volume
//   instead of being silently counted as material. A mesh in the opposite orientation gives a
//   negative volume and mass, the same centroid, and a negated inertia (every moment integrates
//   density times signed volume).
// - Boundary triangles (i, j, k) are outward when (x_j - x_i) x (x_k - x_i) points out of the
//   solid. Surface area and frontal area use only F; volume, centroid and inertia only T.
// - Inertia is the full 3x3 tensor about the centroid, row-major, of a solid of uniform density:
//   I = density * integral (|r|^2 Id - r r^T) dV with r = x - centroid (so the off-diagonal
//   products of inertia carry a minus sign). It is symmetric; both halves are written.
//
// Robustness
// - Indices are the caller's responsibility (every index < #V); nothing is checked here.
// - Non-finite positions never crash; every affected result of mass_properties() is NaN (an
//   infinity that the arithmetic would produce is reported as NaN too). Gradients of
//   non-finite inputs are non-finite (NaN or +-inf) in the entries they reach.
// - Empty inputs give zeros: #T == 0 gives volume, mass, centroid and inertia 0; #F == 0 gives
//   area and frontal area 0. A non-empty tet set whose total signed volume is exactly 0 has no
//   centroid: centroid and inertia are NaN.
//
// Cost: mass_properties() and mass_properties_vjp() each make one pass over T and one over F,
// read V through the indices, accumulate in double, and allocate nothing.
#pragma once

#include <cstddef>
#include <cstdint>

namespace cadinterp::runtime {

/// A tet mesh with its boundary surface, as the runtime evaluates it. Non-owning view.
struct TetMeshView {
  const float* V = nullptr;          ///< V  #V by 3 vertex positions, row-major
  std::size_t num_vertices = 0;      ///< #V
  const std::uint32_t* T = nullptr;  ///< T  #T by 4 tets, positively oriented (see above)
  std::size_t num_tets = 0;          ///< #T
  const std::uint32_t* F = nullptr;  ///< F  #F by 3 boundary triangles, outward oriented
  std::size_t num_faces = 0;         ///< #F
};

struct MassPropertiesOptions {
  double density = 1.0;  ///< uniform density; mass = density * volume, inertia scales with it
  /// Direction d for the frontal area. Expected to be unit length; it is not normalized, so a
  /// non-unit d scales the frontal area (and its gradient) by |d|.
  double direction[3] = {0.0, 0.0, 1.0};
};

/// Every output of mass_properties().
struct MassProperties {
  double volume = 0.0;  ///< sum of signed tet volumes
  double mass = 0.0;    ///< density * volume
  double area = 0.0;    ///< sum of boundary triangle areas
  /// 0.5 * sum_f |n_f . d| A_f over the boundary triangles. For a closed surface
  /// sum_f n_f A_f = 0, so this is the area of the front-facing triangles projected along d:
  /// exactly the silhouette (shadow) area of a convex body, and an upper bound otherwise
  /// (front-facing parts that hide each other are counted once each). A drag proxy.
  double frontal_area = 0.0;
  double centroid[3] = {0.0, 0.0, 0.0};  ///< centre of mass (of the signed volume)
  double inertia[9] = {};                ///< 3 by 3 row-major, about the centroid
};

/// Adjoint weights of every output: mass_properties_vjp() adds
/// d/dV [ volume*bar.volume + mass*bar.mass + area*bar.area + frontal_area*bar.frontal_area
///        + sum_i centroid[i]*bar.centroid[i] + sum_ij inertia[ij]*bar.inertia[ij] ].
/// Inertia entries are treated as 9 separate outputs (bar.inertia need not be symmetric).
/// A one-hot bar gives the gradient of that single output.
struct MassPropertiesBar {
  double volume = 0.0;
  double mass = 0.0;
  double area = 0.0;
  double frontal_area = 0.0;
  double centroid[3] = {0.0, 0.0, 0.0};
  double inertia[9] = {};
};

/// Computes every output in one pass over T and one over F.
/// @param[in] mesh  positions, tets and boundary triangles (indices < #V, not checked)
/// @param[in] opt   density and frontal-area direction
/// @return the outputs; see the file comment for NaN and empty-mesh behaviour.
/// Thread-safety: pure function of its arguments; safe to call concurrently.
MassProperties mass_properties(const TetMeshView& mesh, const MassPropertiesOptions& opt);

/// Vector-Jacobian product: dV += (d outputs / d V)^T bar, hand-derived (not finite
/// differences), one pass over T and one over F, no allocation. A pass is skipped when every
/// bar entry it serves is zero.
///
/// Where an output is not differentiable this returns a one-sided choice that is a valid
/// subgradient: a triangle with zero area contributes 0 to d(area); a triangle with n_f . d == 0
/// contributes 0 to d(frontal_area). Positions of vertices not referenced by T or F get 0.
///
/// @param[in]     mesh   as passed to mass_properties()
/// @param[in]     opt    as passed to mass_properties()
/// @param[in]     props  mass_properties(mesh, opt); only volume and centroid are read
/// @param[in]     bar    adjoint weights of the outputs
/// @param[in,out] dV     #V by 3, row-major, accumulated into (not cleared)
/// Thread-safety: safe to call concurrently with distinct dV.
void mass_properties_vjp(const TetMeshView& mesh, const MassPropertiesOptions& opt,
                         const MassProperties& props, const MassPropertiesBar& bar, double* dV);

}  // namespace cadinterp::runtime
