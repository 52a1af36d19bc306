"""The plain records cadinterp returns: what an asset describes, and a build's report."""
from collections import namedtuple
from dataclasses import asdict, dataclass, field

Parameter = namedtuple("Parameter", "name lower upper unit")
Parameter.__doc__ = "One design parameter: its name, range [lower, upper] and unit ('' if none)."

Field = namedtuple("Field", "name location components unit max_abs_error")
Field.__doc__ = ("A field: location 'vertex' or 'tet', components per row, unit ('' if none), "
                 "and the codec's error bound on stored values (0: lossless).")

Region = namedtuple("Region", "name kind face_tags")
Region.__doc__ = "A boundary-condition region: its kind ('fixed', 'force', ...) and face tags."

Output = namedtuple("Output", "name unit")
Output.__doc__ = ("A per-sample scalar output the host computed exactly (B-rep volume, ...), "
                  "interpolated with the mesh's weights; unit '' if none.")

InfeasiblePoint = namedtuple("InfeasiblePoint", "x message")
InfeasiblePoint.__doc__ = "A point where the builder's host failed, with the host's message."

Provenance = namedtuple("Provenance", "builder_version host options")
Provenance.__doc__ = "How the asset was built: builder version, host name, options (JSON text)."

for _cls in (Parameter, Field, Output, Region, InfeasiblePoint, Provenance):
    _cls.__module__ = "cadinterp"


@dataclass(frozen=True)
class BuildReport:
    """What cadinterp.build did: cadinterp_build_report's members, the stage times and counts
    (cadinterp_build_stages) and the distinct reasons of infeasible points (message, count)."""

    output: str
    samples: int
    host_evaluations: int
    store_hits: int
    infeasible_points: int
    elements: int
    infeasible_elements: int
    stored_meshes: int
    budget_exhausted: bool
    max_error: float
    host_seconds: float
    wall_seconds: float
    asset_bytes: int
    infeasible_reasons: list = field(default_factory=list)
    stages: dict = field(default_factory=dict)

    def as_dict(self):
        return asdict(self)


BuildReport.__module__ = "cadinterp"
