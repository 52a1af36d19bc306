"""The parametric FreeCAD model: a stepped cantilever plate (a thick root block fused to a thin
plate) with a through hole, its dimensions from a Spreadsheet (README.md, "Model"). The hole's
position and radius are the parameters; where the hole crosses the step, the topology changes.

The document is built once; every evaluation writes x into the spreadsheet's aliased cells,
recomputes, and takes the Part::Cut's solid. FreeCAD 0.20 is loaded headless from Debian's
freecad-python3 (no GUI modules are imported).
"""
import math
import sys

FREECAD_LIB = "/usr/lib/freecad-python3/lib"
if FREECAD_LIB not in sys.path:
    sys.path.append(FREECAD_LIB)

import FreeCAD  # noqa: E402  (needs FREECAD_LIB on sys.path)
import Part  # noqa: E402,F401  (registers the Part types the document uses)

# Fixed dimensions (mm) and the design parameters' boxes (name, lower, upper, unit).
LENGTH, WIDTH, THICKNESS = 80.0, 20.0, 5.0  # the plate
STEP, ROOT_THICKNESS = 40.0, 8.0  # the root block: x in [0, STEP], z in [0, ROOT_THICKNESS]
# hole_x in [34, 58], hole_radius in [2.5, 5.5]: the hole lies in the thin plate, across the step
# (hole_x - hole_radius < STEP < hole_x + hole_radius) or in the root block. The box's widths (24
# and 3, both multiples of 3) keep every dyadic grid point of the builder's K-d tree off the
# tangency lines hole_x -+ hole_radius = STEP (they would need a third of a dyadic rational).
PARAMETERS = [("hole_x", 34.0, 58.0, "mm"), ("hole_radius", 2.5, 5.5, "mm")]
# Closer than this to tangency between the hole and the step's edge, the solid has a sliver (a
# neck or a rim thinner than CLEARANCE) that no mesh of sensible size resolves.
CLEARANCE = 0.2
# Face roles (naming.py) of the clamped and the loaded face.
FIXED_ROLE, LOAD_ROLE = "plate.xmin+root.xmin", "plate.xmax"


class InfeasibleError(RuntimeError):
    """x has no valid model (the message says why); the builder records x as infeasible."""


class BracketDocument:
    """A FreeCAD document: Spreadsheet `Params` -> Part::Box `Plate` and `Root`, Part::Fuse
    `Body` (refined: coplanar faces merged), Part::Cylinder `Hole` -> Part::Cut `Bracket`. Not
    thread-safe (one FreeCAD document, recomputed in place)."""

    def __init__(self):
        self.doc = FreeCAD.newDocument("cadinterp_bracket")
        sheet = self.doc.addObject("Spreadsheet::Sheet", "Params")
        cells = [("Length", LENGTH), ("Width", WIDTH), ("Thickness", THICKNESS), ("Step", STEP),
                 ("RootThickness", ROOT_THICKNESS), ("HoleX", 50.0), ("HoleRadius", 4.0)]
        for row, (alias, value) in enumerate(cells, start=1):
            sheet.set("A%d" % row, alias)
            sheet.set("B%d" % row, str(value))
            sheet.setAlias("B%d" % row, alias)
        self.sheet = sheet
        plate = self.doc.addObject("Part::Box", "Plate")
        plate.setExpression("Length", "Params.Length")
        plate.setExpression("Width", "Params.Width")
        plate.setExpression("Height", "Params.Thickness")
        root = self.doc.addObject("Part::Box", "Root")
        root.setExpression("Length", "Params.Step")
        root.setExpression("Width", "Params.Width")
        root.setExpression("Height", "Params.RootThickness")
        body = self.doc.addObject("Part::Fuse", "Body")
        body.Base, body.Tool, body.Refine = plate, root, True
        hole = self.doc.addObject("Part::Cylinder", "Hole")
        hole.setExpression("Radius", "Params.HoleRadius")
        hole.setExpression("Height", "Params.RootThickness + 2")
        hole.setExpression("Placement.Base.x", "Params.HoleX")
        hole.setExpression("Placement.Base.y", "Params.Width / 2")
        hole.setExpression("Placement.Base.z", "-1")
        cut = self.doc.addObject("Part::Cut", "Bracket")
        cut.Base, cut.Tool = body, hole
        self.objects = [sheet, plate, root, body, hole, cut]
        self.plate, self.root, self.hole, self.cut = plate, root, hole, cut
        self.doc.recompute()

    def regenerate(self, x):
        """Sets x (hole_x, hole_radius) into the spreadsheet, recomputes and returns
        (solid, primitives): the cut's solid and [(prefix, primitive shape)] of the features
        whose faces it is made of. Raises InfeasibleError for an x outside the model's domain
        or a recompute that fails."""
        if len(x) != len(PARAMETERS):
            raise InfeasibleError("expected %d parameters, got %d" % (len(PARAMETERS), len(x)))
        hole_x, radius = float(x[0]), float(x[1])
        if not (math.isfinite(hole_x) and math.isfinite(radius)) or radius <= 0:
            raise InfeasibleError("parameters must be finite with hole_radius > 0")
        if not (radius < WIDTH / 2 and radius < hole_x < LENGTH - radius):
            raise InfeasibleError("the hole does not fit in the plate")
        gap = min(abs(hole_x - radius - STEP), abs(hole_x + radius - STEP))
        if gap < CLEARANCE:
            raise InfeasibleError("hole within %g mm of tangency with the step (gap %.3g mm)"
                                  % (CLEARANCE, gap))
        self.sheet.set("HoleX", repr(hole_x))
        self.sheet.set("HoleRadius", repr(radius))
        self.doc.recompute()
        for obj in self.objects:
            if "Invalid" in obj.State or "Error" in obj.State:
                raise InfeasibleError("FreeCAD recompute failed on %s: %s" % (obj.Name, obj.State))
        shape = self.cut.Shape
        if len(shape.Solids) != 1 or not shape.isValid():
            raise InfeasibleError("the cut is not one valid solid (%d solids)" % len(shape.Solids))
        return shape.Solids[0], [("plate", self.plate.Shape), ("root", self.root.Shape),
                                 ("hole", self.hole.Shape)]
