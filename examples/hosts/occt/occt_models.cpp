// The four models of the OCCT host (README.md has their drawings in words, parameters and loads).
// Each is a feature list: primitives named by role, booleans and fillets whose history carries the
// names (occt_naming.h). Parameter ranges are chosen so that most of the box regenerates and a
// corner fails (a fillet that does not fit, a hole that breaks through a wall), as in the paper's
// examples where the CAD system refuses some parameter combinations (§4.2).
#include "occt_models.h"

#include <BRepAdaptor_Curve.hxx>
#include <BRepAlgoAPI_Cut.hxx>
#include <BRepAlgoAPI_Fuse.hxx>
#include <BRepBuilderAPI_MakeEdge.hxx>
#include <BRepBuilderAPI_MakeFace.hxx>
#include <BRepBuilderAPI_MakeWire.hxx>
#include <BRepFilletAPI_MakeFillet.hxx>
#include <BRepPrimAPI_MakeBox.hxx>
#include <BRepPrimAPI_MakeCylinder.hxx>
#include <BRepPrimAPI_MakePrism.hxx>
#include <GC_MakeArcOfCircle.hxx>
#include <GC_MakeSegment.hxx>
#include <TopExp_Explorer.hxx>
#include <TopTools_ListOfShape.hxx>
#include <TopoDS.hxx>
#include <gp_Ax2.hxx>

#include <cmath>
#include <sstream>

namespace cadinterp::occt {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string fmt(double v) {
  std::ostringstream s;
  s.precision(4);
  s << v;
  return s.str();
}

NamedShape box(int feature, const std::string& prefix, double x0, double y0, double z0, double x1,
               double y1, double z1) {
  BRepPrimAPI_MakeBox mk(gp_Pnt(x0, y0, z0), gp_Pnt(x1, y1, z1));
  return name_by_geometry(mk.Shape(), feature, prefix);
}

NamedShape cylinder(int feature, const std::string& prefix, const gp_Pnt& base, const gp_Dir& axis,
                    double radius, double height) {
  BRepPrimAPI_MakeCylinder mk(gp_Ax2(base, axis), radius, height);
  return name_by_geometry(mk.Shape(), feature, prefix);
}

// A slot (obround) through-cut tool: a profile of two flanks and two half-circle ends in the
// plane z = z0, from centre a to centre b (width d), extruded by h. Each face is named by the
// profile edge it was swept from ("side0", "end1", ...), through the prism's history.
NamedShape obround(int feature, const std::string& prefix, const gp_Pnt& a, const gp_Pnt& b,
                   double d, double h) {
  const gp_Vec along(a, b);
  const gp_Vec across = gp_Vec(0, 0, 1).Crossed(along).Normalized() * (d / 2);
  const gp_Vec unit = along.Normalized() * (d / 2);
  const gp_Pnt a0 = a.Translated(across), a1 = a.Translated(-across);
  const gp_Pnt b0 = b.Translated(across), b1 = b.Translated(-across);
  const TopoDS_Edge side0 = BRepBuilderAPI_MakeEdge(GC_MakeSegment(a1, b1).Value());
  const TopoDS_Edge end1 =
      BRepBuilderAPI_MakeEdge(GC_MakeArcOfCircle(b1, b.Translated(unit), b0).Value());
  const TopoDS_Edge side1 = BRepBuilderAPI_MakeEdge(GC_MakeSegment(b0, a0).Value());
  const TopoDS_Edge end0 =
      BRepBuilderAPI_MakeEdge(GC_MakeArcOfCircle(a0, a.Translated(-unit), a1).Value());
  BRepBuilderAPI_MakeWire wire(side0, end1, side1, end0);
  BRepBuilderAPI_MakeFace face(wire.Wire());
  BRepPrimAPI_MakePrism prism(face.Face(), gp_Vec(0, 0, h));
  NamedShape out;
  out.shape = prism.Shape();
  const std::string f = "f" + std::to_string(feature) + ":" + prefix + ".";
  // The wire may rebuild edges to share vertices: find each profile edge by its midpoint.
  const std::pair<gp_Pnt, const char*> roles[] = {{a1.Translated(0.5 * along), "side0"},
                                                  {b.Translated(unit), "end1"},
                                                  {a0.Translated(0.5 * along), "side1"},
                                                  {a.Translated(-unit), "end0"}};
  for (TopExp_Explorer ex(face.Face(), TopAbs_EDGE); ex.More(); ex.Next()) {
    BRepAdaptor_Curve c(TopoDS::Edge(ex.Current()));
    const gp_Pnt mid = c.Value(0.5 * (c.FirstParameter() + c.LastParameter()));
    const char* role = roles[0].second;
    double best = mid.Distance(roles[0].first);
    for (const auto& r : roles)
      if (mid.Distance(r.first) < best) {
        best = mid.Distance(r.first);
        role = r.second;
      }
    for (const TopoDS_Shape& g : prism.Generated(ex.Current()))
      if (g.ShapeType() == TopAbs_FACE) out.faces.Bind(g, FaceName{f + role, {f + role}});
  }
  out.faces.Bind(prism.FirstShape(), FaceName{f + "bottom", {f + "bottom"}});
  out.faces.Bind(prism.LastShape(), FaceName{f + "top", {f + "top"}});
  return out;
}

void check_done(BRepAlgoAPI_BooleanOperation& op, int feature, const char* what) {
  if (!op.IsDone() || op.HasErrors())
    throw Infeasible("feature " + std::to_string(feature) + " (" + what + ") failed");
}

NamedShape fuse(int feature, const NamedShape& a, const NamedShape& b) {
  BRepAlgoAPI_Fuse op(a.shape, b.shape);
  check_done(op, feature, "fuse");
  return propagate(op, feature, {&a, &b});
}

NamedShape cut(int feature, const NamedShape& a, const std::vector<NamedShape>& tools) {
  BRepAlgoAPI_Cut op;
  TopTools_ListOfShape args, tl;
  args.Append(a.shape);
  std::vector<const NamedShape*> inputs{&a};
  for (const NamedShape& t : tools) {
    tl.Append(t.shape);
    inputs.push_back(&t);
  }
  op.SetArguments(args);
  op.SetTools(tl);
  op.SetRunParallel(false);
  op.Build();
  check_done(op, feature, "cut");
  return propagate(op, feature, inputs);
}

NamedShape fillet(int feature, const NamedShape& s, const std::vector<TopoDS_Shape>& edges,
                  double radius, const std::string& what) {
  if (edges.empty())
    throw Infeasible("feature " + std::to_string(feature) + " (" + what + "): no edge to fillet");
  BRepFilletAPI_MakeFillet op(s.shape);
  for (const TopoDS_Shape& e : edges) op.Add(radius, TopoDS::Edge(e));
  op.Build();
  if (!op.IsDone())
    throw Infeasible("feature " + std::to_string(feature) + " (" + what + "): a fillet of radius " +
                     fmt(radius) + " mm does not fit");
  return propagate(op, feature, {&s});
}

// ---- wrench -------------------------------------------------------------------------------
// An open-end wrench in the xy plane, 6 mm thick: a round head at the origin (radius R), a
// handle of width 14 mm along -x (length L), the head-handle junction filleted (r), and the jaw
// slot cut from +x. Fixed at the jaw faces, pulled down (-y) at the handle end; the load angle
// tilts that force out of the plane (it changes the physics only, like the paper's swing).
constexpr double kWrenchT = 6.0, kWrenchW = 14.0;

NamedShape wrench(const double* x) {
  const double R = x[0], L = x[1], r = x[2];
  NamedShape head = cylinder(1, "head", gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1), R, kWrenchT);
  NamedShape handle = box(2, "handle", -L, -kWrenchW / 2, 0, 0, kWrenchW / 2, kWrenchT);
  NamedShape s = fuse(3, head, handle);
  std::vector<TopoDS_Shape> junction = edges_between(s, "f1:head.lateral", "f2:handle.ymin");
  for (const TopoDS_Shape& e : edges_between(s, "f1:head.lateral", "f2:handle.ymax"))
    junction.push_back(e);
  s = fillet(4, s, junction, r, "head-handle fillet");
  const double slot = 0.8 * R;
  s = cut(5, s, {box(5, "jaw", 0.35 * R, -slot / 2, -1, R + 5, slot / 2, kWrenchT + 1)});
  return s;
}

LoadCase wrench_loads(const double* x, const Settings& st) {
  LoadCase c;
  c.fixed.push_back({"jaw"});
  const double a = x[3] * kPi / 180.0;
  c.forces.push_back({"handle_end", {0, -st.force * std::cos(a), st.force * std::sin(a)}});
  return c;
}

// ---- drum brake hub -------------------------------------------------------------------------
// A cup of radius 60 mm and height 40 mm: a 10 mm flange with a 12 mm bore and five bolt holes
// on a 36 mm circle, and a drum rim of thickness t whose inner wall is the braking surface. The
// bolt holes are round (slot length < 0.5 mm) or radial slots of length l: the hole shape
// changes the B-rep topology. A hole that leaves less than 2.5 mm of wall is refused.
constexpr double kHubR = 60, kHubH = 40, kFlange = 10, kBore = 12, kBolt = 36;

NamedShape hub(const double* x) {
  const double d = x[0], l = x[1], t = x[2];
  const double r_out = kBolt + 0.5 * (d + (l < 0.5 ? 0 : l));
  const double r_in = kBolt - 0.5 * (d + (l < 0.5 ? 0 : l));
  if (kHubR - t - r_out < 2.5)
    throw Infeasible("bolt hole breaks into the drum wall: " + fmt(kHubR - t - r_out) +
                     " mm of wall left, 2.5 mm needed");
  if (r_in - kBore < 2.5)
    throw Infeasible("bolt hole breaks into the bore: " + fmt(r_in - kBore) +
                     " mm of wall left, 2.5 mm needed");
  NamedShape s = cylinder(1, "drum", gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1), kHubR, kHubH);
  s = cut(2, s, {cylinder(2, "cavity", gp_Pnt(0, 0, kFlange), gp_Dir(0, 0, 1), kHubR - t, kHubH)});
  s = cut(3, s, {cylinder(3, "bore", gp_Pnt(0, 0, -1), gp_Dir(0, 0, 1), kBore, kFlange + 2)});
  std::vector<NamedShape> holes;
  for (int k = 0; k < 5; ++k) {
    const double phi = 2 * kPi * (k + 0.25) / 5;  // away from the cylinders' seams at angle 0
    const gp_Dir radial(std::cos(phi), std::sin(phi), 0);
    const std::string name = "hole" + std::to_string(k);
    if (l < 0.5) {
      holes.push_back(cylinder(4, name, gp_Pnt(kBolt * radial.X(), kBolt * radial.Y(), -1),
                               gp_Dir(0, 0, 1), d / 2, kFlange + 2));
      continue;
    }
    // A radial slot.
    const double a = kBolt - l / 2, b = kBolt + l / 2;
    holes.push_back(obround(4, name, gp_Pnt(a * radial.X(), a * radial.Y(), -1),
                            gp_Pnt(b * radial.X(), b * radial.Y(), -1), d, kFlange + 2));
  }
  return cut(5, s, holes);
}

LoadCase hub_loads(const double*, const Settings& st) {
  LoadCase c;
  c.thermal = true;
  c.fixed.push_back({"bore"});
  // The shoes press on the braking surface and drag it round: a pressure and a friction force.
  c.pressures.push_back({"braking_surface", 1.0});
  c.forces.push_back({"braking_surface", {0, st.force, 0}});
  c.fluxes.push_back({"braking_surface", st.heat_flux});
  c.convections.push_back({"outer_wall", 1e-4, 20.0});
  c.temperatures.push_back({"bore", 20.0});
  return c;
}

// ---- arbor press frame ------------------------------------------------------------------------
// A C-frame plate 40 mm thick: a block W x H with the throat cut from the open side, leaving a
// spine of thickness s and two 40 mm arms; the throat's inner corners filleted (r); the ram bore
// (d) through the upper arm. A large ram bore reaches into the upper fillet, splitting its edges;
// a fillet larger than half the throat does not fit. This is the optimization example.
constexpr double kPressT = 40, kPressArm = 40;

NamedShape press(const double* x) {
  const double H = x[0], W = x[1], r = x[2], s = x[3], d = x[4];
  if (2 * r > H - 2 * kPressArm - 1)
    throw Infeasible("throat fillets of radius " + fmt(r) + " mm do not fit a throat " +
                     fmt(H - 2 * kPressArm) + " mm high");
  NamedShape b = box(1, "body", 0, 0, 0, W, H, kPressT);
  b = cut(2, b, {box(2, "throat", s, kPressArm, -1, W + 5, H - kPressArm, kPressT + 1)});
  std::vector<TopoDS_Shape> corners = edges_between(b, "f2:throat.xmin", "f2:throat.ymin");
  for (const TopoDS_Shape& e : edges_between(b, "f2:throat.xmin", "f2:throat.ymax"))
    corners.push_back(e);
  b = fillet(3, b, corners, r, "throat fillets");
  const double xc = s + 0.6 * (W - s);
  // The bore starts 10 mm below the arm (the ram guide's counterbore side), so a bore that
  // overlaps the fillet cuts through it.
  return cut(4, b,
             {cylinder(4, "ram", gp_Pnt(xc, H - kPressArm - 10, kPressT / 2), gp_Dir(0, 1, 0),
                       d / 2, kPressArm + 11)});
}

LoadCase press_loads(const double*, const Settings& st) {
  LoadCase c;
  c.fixed.push_back({"base"});
  // The ram pushes the work down on the table and the frame's head up: equal and opposite.
  c.forces.push_back({"ram_bore", {0, st.force, 0}});
  c.forces.push_back({"table", {0, -st.force, 0}});
  return c;
}

// ---- camera mount
// --------------------------------------------------------------------------------- An L bracket of
// thickness t: a base plate a x b with two punched mounting holes, an upright of height h with the
// punched camera-screw hole, the inner bend filleted (rb). Each hole is centred halfway between
// the fillet's tangent edge and its plate's end and must stay 1.5 mm clear of the end, so it also
// stays 1.5 mm clear of the fillet: the topology is the same over the whole feasible box.
NamedShape mount(const double* x) {
  const double a = x[0], h = x[1], b = x[2], t = x[3], rb = x[4], d = x[5];
  NamedShape base = box(1, "base", 0, 0, 0, a, b, t);
  NamedShape upright = box(2, "upright", 0, 0, 0, t, b, h);
  NamedShape s = fuse(3, base, upright);
  s = fillet(4, s, edges_between(s, "f1:base.zmax", "f2:upright.xmax"), rb, "bend fillet");
  const double xb = 0.5 * (t + rb + a), zu = 0.5 * (t + rb + h);
  if (xb + d / 2 > a - 1.5)
    throw Infeasible("mounting holes of " + fmt(d) + " mm do not fit the base");
  if (zu + d / 2 > h - 1.5)
    throw Infeasible("camera-screw hole of " + fmt(d) + " mm does not fit the upright");
  std::vector<NamedShape> holes;
  holes.push_back(cylinder(5, "mount0", gp_Pnt(xb, 0.25 * b, -1), gp_Dir(0, 0, 1), d / 2, t + 2));
  holes.push_back(cylinder(5, "mount1", gp_Pnt(xb, 0.75 * b, -1), gp_Dir(0, 0, 1), d / 2, t + 2));
  holes.push_back(cylinder(5, "screw", gp_Pnt(-1, 0.5 * b, zu), gp_Dir(1, 0, 0), d / 2, t + 2));
  return cut(5, s, holes);
}

LoadCase mount_loads(const double*, const Settings& st) {
  LoadCase c;
  c.fixed.push_back({"mounting_holes"});
  c.forces.push_back({"camera_screw", {0, 0, -st.force}});
  return c;
}

std::vector<ModelDef> make_models() {
  std::vector<ModelDef> m;
  {
    ModelDef d;
    d.name = "wrench";
    d.description = "open-end wrench: head, handle, head-handle fillet, jaw slot";
    d.default_mesh_size = 4.0;
    d.default_force = 200.0;
    d.parameters = {{"head_radius", "mm", 12, 20},
                    {"handle_length", "mm", 80, 140},
                    {"head_fillet", "mm", 1, 12},
                    {"load_angle", "deg", -30, 30}};
    d.regions = {{"jaw", "fixed", {"f5:jaw.ymin", "f5:jaw.ymax"}},
                 {"handle_end", "force", {"f2:handle.xmin"}}};
    d.build = wrench;
    d.loads = wrench_loads;
    m.push_back(d);
  }
  {
    ModelDef d;
    d.name = "hub";
    d.description = "drum brake hub: drum, cavity, bore, five bolt holes (round or slotted)";
    d.default_mesh_size = 8.0;
    d.default_force = 2000.0;
    d.parameters = {{"hole_diameter", "mm", 6, 14},
                    {"hole_slot_length", "mm", 0, 12},
                    {"rim_thickness", "mm", 3, 10}};
    d.regions = {{"braking_surface", "heat", {"f2:cavity.lateral"}},
                 {"bore", "fixed", {"f3:bore.lateral"}},
                 {"outer_wall", "convection", {"f1:drum.lateral"}}};
    d.build = hub;
    d.loads = hub_loads;
    m.push_back(d);
  }
  {
    ModelDef d;
    d.name = "press";
    d.description = "arbor press C-frame: block, throat, throat fillets, ram bore";
    d.default_mesh_size = 12.0;
    d.default_force = 10000.0;
    d.parameters = {{"height", "mm", 150, 250},
                    {"width", "mm", 100, 160},
                    {"throat_fillet", "mm", 5, 40},
                    {"spine_thickness", "mm", 15, 35},
                    {"ram_bore", "mm", 10, 30}};
    d.regions = {{"base", "fixed", {"f1:body.ymin"}},
                 {"ram_bore", "force", {"f4:ram.lateral"}},
                 {"table", "force", {"f2:throat.ymin"}}};
    d.build = press;
    d.loads = press_loads;
    m.push_back(d);
  }
  {
    ModelDef d;
    d.name = "mount";
    d.description = "camera mount: L bracket, bend fillet, punched holes";
    d.default_mesh_size = 4.0;
    d.default_force = 50.0;
    d.parameters = {{"base_length", "mm", 40, 80}, {"height", "mm", 30, 70},
                    {"width", "mm", 30, 50},       {"thickness", "mm", 3, 8},
                    {"bend_radius", "mm", 1, 10},  {"hole_diameter", "mm", 4, 12}};
    d.regions = {{"mounting_holes", "fixed", {"f5:mount0.lateral", "f5:mount1.lateral"}},
                 {"camera_screw", "force", {"f5:screw.lateral"}}};
    d.build = mount;
    d.loads = mount_loads;
    m.push_back(d);
  }
  return m;
}

}  // namespace

const std::vector<ModelDef>& models() {
  static const std::vector<ModelDef> all = make_models();
  return all;
}

const ModelDef* find_model(const std::string& name) {
  for (const ModelDef& m : models())
    if (m.name == name) return &m;
  return nullptr;
}

}  // namespace cadinterp::occt
