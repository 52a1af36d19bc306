// Beam theory on the OCCT models' straight parts (occt_beam.h). The dimensions repeat
// occt_models.cpp's (the wrench's 14 x 6 mm handle, the press's 40 mm plate) and the loads its
// load cases at the default forces; the bands keep about one section depth away from the load,
// the fixtures and the fillets (Saint-Venant), where beam theory is exact for these loads.
#include "occt_beam.h"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace cadinterp::occt {
namespace {

constexpr double kE = 210e3;  // the host's steel (occt_host.cpp), MPa

/// One straight part: the band's axial range and the section, in the model's coordinates.
struct Beam {
  int axial = 0, bending = 1, thickness = 2;  // coordinate indices
  double a0 = 0, a1 = 0;                      // the band along the axis
  double b_lo = 0, b_hi = 0;                  // the section's faces across the bending direction
  double c_mid = 0;                           // the section's middle through the thickness
  double area = 0, inertia = 0;
  double normal = 0;                          // axial force N (tension positive)
  double moment_at_a0 = 0, moment_slope = 0;  // |M|(a) = moment_at_a0 + moment_slope (a - a0)
};

Beam wrench_beam(const std::vector<double>& x) {
  // Parameters: head_radius, handle_length, head_fillet, load_angle (0 at the centre). The
  // handle runs from -L to the fillet's tangent point near x = -18 at the centre.
  const double L = x[1], w = 14, t = 6, F = 200;
  if (std::abs(x[3]) > 1e-12) throw std::runtime_error("beam check: the load must be in-plane");
  Beam b;
  b.axial = 0;
  b.bending = 1;
  b.thickness = 2;
  b.a0 = -L + 20;
  b.a1 = -L + 70;
  b.b_lo = -w / 2;
  b.b_hi = w / 2;
  b.c_mid = t / 2;
  b.area = w * t;
  b.inertia = t * w * w * w / 12;
  b.moment_at_a0 = F * 20;  // the end load's arm at the band's start
  b.moment_slope = F;
  return b;
}

Beam press_beam(const std::vector<double>& x) {
  // Parameters: height, width, throat_fillet, spine_thickness, ram_bore. Above a cut through
  // the spine the only load is the ram's F (+y) at the bore's axis xc: tension F and the
  // constant moment F (xc - s/2).
  const double H = x[0], W = x[1], s = x[3], T = 40, F = 10000;
  const double xc = s + 0.6 * (W - s);
  Beam b;
  b.axial = 1;
  b.bending = 0;
  b.thickness = 2;
  b.a0 = H / 2 - 15;  // the straight spine is H/2 +- 37.5 at the centre: 22.5 mm clear
  b.a1 = H / 2 + 15;
  b.b_lo = 0;
  b.b_hi = s;
  b.c_mid = T / 2;
  b.area = s * T;
  b.inertia = T * s * s * s / 12;
  b.normal = F;
  b.moment_at_a0 = F * (xc - s / 2);
  return b;
}

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// Stress errors on the band's two bending faces: von Mises against |N/A + M c/I| (inner face,
/// b_hi) and |N/A - M c/I| (b_lo).
void stress_errors(const Beam& b, const Evaluation& e, const Fields& f, BeamCheck& out) {
  const double tol = 1e-6 * (b.b_hi - b.b_lo), c = 0.5 * (b.b_hi - b.b_lo);
  double sum = 0;
  for (std::size_t v = 0; v < e.vertices.size() / 3; ++v) {
    const double* p = &e.vertices[3 * v];
    const double a = p[b.axial], y = p[b.bending];
    if (a < b.a0 || a > b.a1) continue;
    const bool hi = std::abs(y - b.b_hi) < tol, lo = std::abs(y - b.b_lo) < tol;
    if (!hi && !lo) continue;
    const double bending = (b.moment_at_a0 + b.moment_slope * (a - b.a0)) * c / b.inertia;
    const double want = std::abs(b.normal / b.area + (hi ? bending : -bending));
    const double err = std::abs(f.von_mises[v] - want) / want;
    out.stress_max = std::max(out.stress_max, err);
    sum += err;
    ++out.stress_vertices;
  }
  if (out.stress_vertices == 0) throw std::runtime_error("beam check: no vertex on the band");
  out.stress_mean = sum / out.stress_vertices;
}

/// The curvature of the deflection at the band's middle: u_b fitted over the band's vertices by
/// the polynomial that holds Saint-Venant's solution for an end-loaded beam (cubic along the
/// axis, the Poisson terms across), its second axial derivative against |M| / (E I).
double curvature_error(const Beam& b, const Evaluation& e, const Fields& f) {
  const double am = 0.5 * (b.a0 + b.a1), bm = 0.5 * (b.b_lo + b.b_hi);
  std::vector<std::array<double, 13>> rows;
  std::vector<double> rhs;
  for (std::size_t v = 0; v < e.vertices.size() / 3; ++v) {
    const double* p = &e.vertices[3 * v];
    if (p[b.axial] < b.a0 || p[b.axial] > b.a1) continue;
    const double a = p[b.axial] - am, y = p[b.bending] - bm, z = p[b.thickness] - b.c_mid;
    rows.push_back(
        {1, a, a * a, a * a * a, y, z, y * y, z * z, y * z, a * y, a * z, a * y * y, a * z * z});
    rhs.push_back(f.displacement[3 * v + static_cast<std::size_t>(b.bending)]);
  }
  if (rows.size() < 26) throw std::runtime_error("beam check: too few vertices to fit");
  Eigen::MatrixXd A(static_cast<Eigen::Index>(rows.size()), 13);
  Eigen::VectorXd r(static_cast<Eigen::Index>(rows.size()));
  for (std::size_t i = 0; i < rows.size(); ++i) {
    for (int k = 0; k < 13; ++k) A(static_cast<Eigen::Index>(i), k) = rows[i][k];
    r[static_cast<Eigen::Index>(i)] = rhs[i];
  }
  const Eigen::VectorXd c = A.colPivHouseholderQr().solve(r);
  const double kappa = 2 * c[2];  // at a = 0, the band's middle
  const double want = (b.moment_at_a0 + b.moment_slope * (am - b.a0)) / (kE * b.inertia);
  return std::abs(std::abs(kappa) - want) / want;
}

}  // namespace

BeamCheck beam_check(const std::string& model, const std::string& options) {
  if (model != "wrench" && model != "press")
    throw std::runtime_error("beam check: no beam check for model '" + model + "'");
  if (options.find("force=") != std::string::npos || options.find("vary=") != std::string::npos)
    throw std::invalid_argument("beam check: the default force and every parameter are needed");
  const Model m(model, options);
  const std::vector<double> x = m.center();
  const Beam b = model == "wrench" ? wrench_beam(x) : press_beam(x);
  BeamCheck out;
  out.model = model;
  out.options = options;
  double t0 = now();
  const Evaluation e = m.evaluate(x.data());
  if (!e.ok) throw std::runtime_error("beam check: " + model + " fails: " + e.message);
  out.evaluate_seconds = now() - t0;
  t0 = now();
  const Fields f = m.simulate(x.data(), e);
  out.simulate_seconds = now() - t0;
  out.tets = static_cast<int>(e.tets.size() / 4);
  stress_errors(b, e, f, out);
  out.curvature = curvature_error(b, e, f);
  return out;
}

}  // namespace cadinterp::occt
