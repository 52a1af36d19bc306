// The OpenCASCADE example host (paper §7, Figure 20 / Table 1): parametric models regenerated
// by OCCT feature lists, tessellated by BRepMesh, tetrahedralized by TetGen and simulated by the
// examples' FEM (examples/physics), behind the builder's C callbacks (cadinterp_builder.h).
//
// The shared library libcadinterp_host_occt.so exports only cadinterp_host_entry; this C++
// interface is for the static library cadinterp_host_occt_static (tests and tools).
// Models, parameters, options and the ID scheme are described in README.md.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cadinterp/cadinterp_builder.h"

#if defined(__GNUC__) || defined(__clang__)
#define OCCT_HOST_EXPORT __attribute__((visibility("default")))
#else
#define OCCT_HOST_EXPORT
#endif

extern "C" {
/**
 * The library's entry point (cadinterp_host_entry_fn).
 * @param[in] model    "wrench" (default), "hub", "press", "mount"
 * @param[in] options  "key=value,..." : mesh_size=MM, order=1|2, levels=0..4 (edge subdivision
 *                     levels of the control points), keep_surface=0|1 (TetGen -Y),
 *                     force=N, heat_flux=W/mm^2 (hub), vary=NAME+NAME (only these
 *                     parameters are the host's; the others stay at the box's centre)
 * @param[out] error   a message in library-owned storage on failure (may be NULL)
 * @return the host (the same one for equal requests), valid until the library is unloaded.
 * Thread-safety: safe.
 */
OCCT_HOST_EXPORT const cadinterp_host* cadinterp_host_entry(const char* model, const char* options,
                                                            const char** error);
}

namespace cadinterp::occt {

/// Seconds spent per stage, summed over the evaluations of a model (thread-safe counters).
struct StageTimes {
  int regenerations = 0;  ///< regenerate calls that reached the kernel
  int failures = 0;       ///< of which infeasible
  double regenerate = 0, tessellate = 0, tetgen = 0, references = 0, physics = 0;
};

struct ControlPoint {
  std::vector<std::int64_t> id;
  double position[3];
};
struct Path {
  std::vector<std::int64_t> a, b;
  std::vector<double> polyline;  ///< #P by 3
};
struct Region {
  std::string name, kind;
  std::vector<std::int32_t> tags;
};

/// Everything one regeneration produced.
struct Evaluation {
  bool ok = false;
  std::string message;  ///< why not ok
  std::vector<double> vertices;
  std::vector<std::uint32_t> tets, triangles;
  std::vector<std::int32_t> triangle_tags;
  std::vector<ControlPoint> points;
  std::vector<Path> paths;
  std::vector<Region> regions;
  /// The B-rep's faces: stable tag and label (occt_naming.h).
  std::vector<std::pair<std::int32_t, std::string>> faces;
  double exact_volume = 0;  ///< BRepGProp::VolumeProperties of the solid
  double mesh_volume = 0;   ///< sum of the tets' volumes
};

/// Fields of one simulation (per vertex), in the models' units: mm, N, MPa, degrees Celsius.
struct Fields {
  std::vector<double> von_mises, displacement, temperature;
  /// #V by 3: the surface traction the FEM applied (MPa = N/mm^2), per vertex the area-weighted
  /// mean over the loaded boundary triangles around it; zero off loaded faces.
  std::vector<double> traction;
};

class Model {
 public:
  /// Throws std::invalid_argument naming an unknown model or a malformed option.
  Model(const std::string& model, const std::string& options);
  ~Model();
  Model(const Model&) = delete;
  Model& operator=(const Model&) = delete;

  const std::string& name() const;
  /// e.g. "occt wrench v1 (mesh_size=4, order=1, levels=1, keep_surface=0, force=200)".
  const std::string& identity() const;
  int parameter_count() const;
  const cadinterp_parameter_desc* parameters() const;
  /// The parameter box's centre.
  std::vector<double> center() const;

  /// Regenerates, meshes and names the model at x (K values). Never throws: a failure gives
  /// ok = false and a message (Standard_Failure, invalid solid, TetGen, ...).
  Evaluation evaluate(const double* x) const;
  /// The boundary-condition regions at x (ok, message and regions; the rest empty): an earlier
  /// successful evaluate or named at the same x if any (the last 4096 x kept), else the solid
  /// regenerated and named without meshing. Never throws but std::bad_alloc.
  std::shared_ptr<const Evaluation> named(const double* x) const;
  /// The exact volume of the solid at x (BRepGProp); throws std::runtime_error if x fails.
  double exact_volume(const double* x) const;
  /// Runs the FEM on an evaluation's mesh and regions (throws std::runtime_error, or
  /// physics::Error).
  Fields simulate(const double* x, const Evaluation& e) const;
  /// Whether this build links the FEM (examples/physics).
  static bool has_physics();
  /// True when the hub's temperature field is part of the fields.
  bool thermal() const;

  StageTimes stage_times() const;
  void reset_stage_times() const;

  /// The host the builder sees; `user` is this model.
  const cadinterp_host* host() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

/// The model names: "wrench", "hub", "press", "mount".
std::vector<std::string> model_names();

/// The model behind a host returned by cadinterp_host_entry of this (static) library; nullptr
/// for any other host.
const Model* host_model(const cadinterp_host* host);

}  // namespace cadinterp::occt
