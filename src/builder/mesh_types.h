// The builder's vocabulary from src/mesh: every stage of a build passes these samples, mappers
// and the host adapter around, so the builder names them without the module prefix.
#pragma once

#include "mesh/host_call.h"
#include "mesh/mapper.h"
#include "mesh/sample.h"
#include "mesh/surface_distance.h"

namespace cadinterp::builder {

using mesh::bbox_diagonal;
using mesh::ControlPoint;
using mesh::deserialize;
using mesh::Field;
using mesh::Host;
using mesh::IdentityMapper;
using mesh::MappedSample;
using mesh::Mapper;
using mesh::Path;
using mesh::Region;
using mesh::same_combinatorics;
using mesh::Sample;
using mesh::serialize;
using mesh::SurfaceIndex;
using mesh::symmetric_hausdorff;
using mesh::validate;
using mesh::vertex_distances;

}  // namespace cadinterp::builder
