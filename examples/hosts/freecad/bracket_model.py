"""The parametric FreeCAD model: a cantilever plate with a through hole whose dimensions come
from a Spreadsheet (README.md, "Model").

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
LENGTH, WIDTH, THICKNESS, HOLE_X = 80.0, 20.0, 5.0, 45.0
PARAMETERS = [("hole_offset", 0.0, 8.0, "mm"), ("hole_radius", 3.0, 6.0, "mm")]
# Closer than this to tangency between the hole and the side face y = WIDTH, the solid has a
# sliver (a ligament or a notch thinner than CLEARANCE) that no mesh of sensible size resolves.
CLEARANCE = 0.25


class InfeasibleError(RuntimeError):
    """x has no valid model (the message says why); the builder records x as infeasible."""


class BracketDocument:
    """A FreeCAD document: Spreadsheet `Params` -> Part::Box `Plate`, Part::Cylinder `Hole`
    -> Part::Cut `Bracket`. Not thread-safe (one FreeCAD document, recomputed in place)."""

    def __init__(self):
        self.doc = FreeCAD.newDocument("cadinterp_bracket")
        sheet = self.doc.addObject("Spreadsheet::Sheet", "Params")
        cells = [("Length", LENGTH), ("Width", WIDTH), ("Thickness", THICKNESS),
                 ("HoleX", HOLE_X), ("HoleOffset", 3.0), ("HoleRadius", 4.0)]
        for row, (alias, value) in enumerate(cells, start=1):
            sheet.set("A%d" % row, alias)
            sheet.set("B%d" % row, str(value))
            sheet.setAlias("B%d" % row, alias)
        self.sheet = sheet
        plate = self.doc.addObject("Part::Box", "Plate")
        plate.setExpression("Length", "Params.Length")
        plate.setExpression("Width", "Params.Width")
        plate.setExpression("Height", "Params.Thickness")
        hole = self.doc.addObject("Part::Cylinder", "Hole")
        hole.setExpression("Radius", "Params.HoleRadius")
        hole.setExpression("Height", "Params.Thickness + 2")
        # The cylinder's seam (its local +x) turned to +y, towards the side face: where the hole
        # breaks through, the seam is cut away and the wall stays one face.
        hole.Placement = FreeCAD.Placement(FreeCAD.Vector(), FreeCAD.Rotation(FreeCAD.Vector(0, 0, 1), 90))
        hole.setExpression("Placement.Base.x", "Params.HoleX")
        hole.setExpression("Placement.Base.y", "Params.Width / 2 + Params.HoleOffset")
        hole.setExpression("Placement.Base.z", "-1")
        cut = self.doc.addObject("Part::Cut", "Bracket")
        cut.Base, cut.Tool = plate, hole
        self.plate, self.hole, self.cut = plate, hole, cut
        self.doc.recompute()

    def regenerate(self, x):
        """Sets x (hole_offset, hole_radius) into the spreadsheet, recomputes and returns
        (solid, primitives): the cut's solid and [(prefix, primitive shape)] of the features
        whose faces it is made of. Raises InfeasibleError for an x outside the model's domain
        or a recompute that fails."""
        if len(x) != len(PARAMETERS):
            raise InfeasibleError("expected %d parameters, got %d" % (len(PARAMETERS), len(x)))
        offset, radius = float(x[0]), float(x[1])
        if not (math.isfinite(offset) and math.isfinite(radius)) or radius <= 0:
            raise InfeasibleError("parameters must be finite with hole_radius > 0")
        gap = WIDTH / 2 - (offset + radius)  # > 0: a ligament; < 0: the hole breaks through
        if abs(gap) < CLEARANCE:
            raise InfeasibleError("hole within %g mm of tangency with the side face (gap %.3g mm)"
                                  % (CLEARANCE, gap))
        self.sheet.set("HoleOffset", repr(offset))
        self.sheet.set("HoleRadius", repr(radius))
        self.doc.recompute()
        for obj in (self.sheet, self.plate, self.hole, self.cut):
            if "Invalid" in obj.State or "Error" in obj.State:
                raise InfeasibleError("FreeCAD recompute failed on %s: %s" % (obj.Name, obj.State))
        shape = self.cut.Shape
        if len(shape.Solids) != 1 or not shape.isValid():
            raise InfeasibleError("the cut is not one valid solid (%d solids)" % len(shape.Solids))
        return shape.Solids[0], [("plate", self.plate.Shape), ("hole", self.hole.Shape)]
