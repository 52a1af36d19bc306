// The OCCT host's FEM against beam theory on the straight parts of two models (README
// "Physics"): the wrench handle (a cantilever under the end load) and the press spine (tension
// plus a constant bending moment). Used by occt_beam_tests (CI, default settings) and by
// `cadinterp-occt-results --beam` (the convergence table over element order and mesh size).
#pragma once

#include <string>

#include "occt_host.h"

namespace cadinterp::occt {

/// Errors of one model's FEM at the box centre against beam theory.
struct BeamCheck {
  std::string model, options;
  /// Bending stress: von Mises at the surface vertices of the band (uniaxial there in beam
  /// theory) against |N/A +- M c / I|; the largest and the mean relative error.
  double stress_max = 0, stress_mean = 0;
  int stress_vertices = 0;
  /// Displacement: the bending curvature of the displacement field (a least-squares polynomial
  /// fit of the deflection over every vertex of the band) against M / (E I), relative.
  double curvature = 0;
  int tets = 0;
  double evaluate_seconds = 0;  ///< regeneration, meshing and references
  double simulate_seconds = 0;  ///< the FEM
};

/// Regenerates and simulates `model` ("wrench" or "press") at its box centre with `options`
/// (the host's) and compares with beam theory. Throws std::runtime_error when the model fails
/// there or has no beam check, std::invalid_argument on bad options.
BeamCheck beam_check(const std::string& model, const std::string& options);

}  // namespace cadinterp::occt
