// The OCCT host's models (README.md): each a feature list that regenerates a named B-rep from a
// parameter vector, the boundary-condition regions named on the features that create their
// faces, and the loads the FEM solves with.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "occt_naming.h"

namespace cadinterp::occt {

/// A regeneration that cannot give a valid solid (fillet too large, wall too thin, ...): the
/// point is infeasible with this message.
struct Infeasible : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct ParameterDef {
  std::string name, unit;
  double lower, upper;
};

/// A boundary-condition region: the faces descending from any of `roots` (face roles).
struct RegionDef {
  std::string name, kind;
  std::vector<std::string> roots;
};

/// Settings shared by every model, from the host options.
struct Settings {
  double force = 0;      ///< N, the model's main load (model default when <= 0)
  double heat_flux = 0;  ///< W/mm^2 (hub; model default when <= 0)
};

/// Loads of one point, on regions by name (physics.h types are filled by the host).
struct LoadCase {
  struct Fix {
    std::string region;
  };
  struct Force {
    std::string region;
    double force[3];
  };
  struct Pressure {
    std::string region;
    double pressure;
  };
  struct Flux {
    std::string region;
    double flux;
  };
  struct Convection {
    std::string region;
    double coefficient, ambient;
  };
  struct Temperature {
    std::string region;
    double temperature;
  };
  std::vector<Fix> fixed;
  std::vector<Force> forces;
  std::vector<Pressure> pressures;
  std::vector<Flux> fluxes;
  std::vector<Convection> convections;
  std::vector<Temperature> temperatures;
  bool thermal = false;
  double reference_temperature = 20.0;
};

struct ModelDef {
  std::string name;
  // In the host identity: 2 since the bisection's new vertices are projected onto the B-rep
  // (occt_mesh.cpp, project_onto_brep), so stores of v1 meshes are refused.
  int version = 2;
  std::string description;
  double default_mesh_size = 5.0;  ///< mm
  double default_force = 100.0;    ///< N
  std::vector<ParameterDef> parameters;
  std::vector<RegionDef> regions;
  /// The feature list: throws Infeasible (or Standard_Failure) when it cannot regenerate.
  std::function<NamedShape(const double* x)> build;
  std::function<LoadCase(const double* x, const Settings& s)> loads;
};

/// The models by name: "wrench" (default), "hub", "press", "mount".
const std::vector<ModelDef>& models();
/// nullptr when unknown.
const ModelDef* find_model(const std::string& name);

}  // namespace cadinterp::occt
