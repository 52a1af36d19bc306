#!/usr/bin/env python3
"""Validates the mesh files `cadinterp eval` writes, independently of the writer's code.

  check_exports.py vtu  FILE --vertices V --cells T      (tets)
  check_exports.py obj  FILE --vertices V --triangles F
  check_exports.py gltf FILE --vertices V --triangles F  (.gltf or .glb)

VTU: well-formed XML, the declared counts, every DataArray decodes (ASCII or VTK's inline base64
with a UInt64 size header) to the length its component count and the piece's counts imply,
connectivity in range, offsets 4, 8, ..., cell types all VTK_TETRA (10).
OBJ: vertex and face counts, 1-based face indices in range, every vertex used.
glTF: the JSON parses, version 2.0, every accessor lies inside its buffer view and buffer,
min/max equal the values actually stored, indices are below the POSITION count; for .glb the
header and chunk layout. Exit status 0 if valid, 1 with a message otherwise (no numpy needed).
"""
import argparse
import base64
import json
import math
import struct
import sys
import xml.etree.ElementTree as ET

VTK_TYPES = {
    "Int8": "b", "UInt8": "B", "Int16": "h", "UInt16": "H", "Int32": "i", "UInt32": "I",
    "Int64": "q", "UInt64": "Q", "Float32": "f", "Float64": "d",
}


class Invalid(Exception):
    pass


def require(cond, msg):
    if not cond:
        raise Invalid(msg)


def vtu_array(da, header_type):
    kind = VTK_TYPES.get(da.get("type"))
    require(kind is not None, "unknown DataArray type %r" % da.get("type"))
    fmt = da.get("format", "ascii")
    text = (da.text or "").strip()
    if fmt == "ascii":
        conv = float if kind in "fd" else int
        return [conv(t) for t in text.split()]
    require(fmt == "binary", "unsupported DataArray format %r" % fmt)
    raw = base64.b64decode(text, validate=True)
    hsize = struct.calcsize("<" + header_type)
    require(len(raw) >= hsize, "binary DataArray shorter than its header")
    (nbytes,) = struct.unpack_from("<" + header_type, raw, 0)
    require(len(raw) == hsize + nbytes,
            "binary DataArray: header says %d bytes, %d present" % (nbytes, len(raw) - hsize))
    size = struct.calcsize("<" + kind)
    require(nbytes % size == 0, "binary DataArray length not a multiple of its type")
    return list(struct.unpack_from("<%d%s" % (nbytes // size, kind), raw, hsize))


def check_vtu(path, vertices, cells):
    root = ET.parse(path).getroot()
    require(root.tag == "VTKFile" and root.get("type") == "UnstructuredGrid", "not a VTU file")
    require(root.get("byte_order") == "LittleEndian", "byte order")
    header_type = {"UInt32": "I", "UInt64": "Q"}[root.get("header_type", "UInt32")]
    pieces = root.findall("./UnstructuredGrid/Piece")
    require(len(pieces) == 1, "expected one Piece")
    piece = pieces[0]
    nv, nc = int(piece.get("NumberOfPoints")), int(piece.get("NumberOfCells"))
    require(nv == vertices, "NumberOfPoints %d, expected %d" % (nv, vertices))
    require(nc == cells, "NumberOfCells %d, expected %d" % (nc, cells))
    pts = piece.findall("./Points/DataArray")
    require(len(pts) == 1 and pts[0].get("NumberOfComponents") == "3", "Points array")
    p = vtu_array(pts[0], header_type)
    require(len(p) == 3 * nv, "Points: %d values for %d points" % (len(p), nv))
    require(all(math.isfinite(v) for v in p), "non-finite point coordinate")
    arrays = {da.get("Name"): da for da in piece.findall("./Cells/DataArray")}
    for name in ("connectivity", "offsets", "types"):
        require(name in arrays, "Cells lacks %s" % name)
    conn = vtu_array(arrays["connectivity"], header_type)
    offs = vtu_array(arrays["offsets"], header_type)
    types = vtu_array(arrays["types"], header_type)
    require(len(conn) == 4 * nc, "connectivity length %d for %d tets" % (len(conn), nc))
    require(all(0 <= i < nv for i in conn), "connectivity index out of range")
    require(offs == [4 * (c + 1) for c in range(nc)], "offsets are not 4, 8, ...")
    require(types == [10] * nc, "cell types are not all VTK_TETRA")
    fields = 0
    for section, count in (("PointData", nv), ("CellData", nc)):
        for da in piece.findall("./%s/DataArray" % section):
            comps = int(da.get("NumberOfComponents", "1"))
            v = vtu_array(da, header_type)
            require(len(v) == comps * count, "%s %s: %d values, expected %d" %
                    (section, da.get("Name"), len(v), comps * count))
            fields += 1
    return "%d points, %d tets, %d field arrays" % (nv, nc, fields)


def check_obj(path, vertices, triangles):
    nv = 0
    faces = []
    with open(path) as f:
        for line in f:
            t = line.split()
            if not t or t[0].startswith("#"):
                continue
            if t[0] == "v":
                require(len(t) == 4 and all(math.isfinite(float(x)) for x in t[1:]), "bad v line")
                nv += 1
            elif t[0] == "f":
                require(len(t) == 4, "face is not a triangle: %r" % line)
                faces.append([int(x.split("/")[0]) for x in t[1:]])
    require(nv == vertices, "%d vertices, expected %d" % (nv, vertices))
    require(len(faces) == triangles, "%d faces, expected %d" % (len(faces), triangles))
    used = set()
    for f in faces:
        for i in f:
            require(1 <= i <= nv, "face index %d out of range" % i)
            used.add(i)
    require(len(used) == nv, "%d vertices unused by faces" % (nv - len(used)))
    return "%d vertices, %d triangles" % (nv, len(faces))


GLTF_COMPONENTS = {5120: "b", 5121: "B", 5122: "h", 5123: "H", 5125: "I", 5126: "f"}
GLTF_TYPES = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def load_gltf(path):
    data = open(path, "rb").read()
    if data[:4] != b"glTF":
        doc = json.loads(data.decode("utf-8"))
        uri = doc["buffers"][0].get("uri", "")
        prefix = "data:application/octet-stream;base64,"
        require(uri.startswith(prefix), "buffer is not an embedded base64 data URI")
        return doc, base64.b64decode(uri[len(prefix):], validate=True)
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    require(version == 2, "GLB version %d" % version)
    require(length == len(data), "GLB length %d, file %d" % (length, len(data)))
    jlen, jtype = struct.unpack_from("<II", data, 12)
    require(jtype == 0x4E4F534A and jlen % 4 == 0, "first chunk must be JSON, 4-aligned")
    doc = json.loads(data[20:20 + jlen].decode("utf-8"))
    off = 20 + jlen
    blen, btype = struct.unpack_from("<II", data, off)
    require(btype == 0x004E4942 and blen % 4 == 0, "second chunk must be BIN, 4-aligned")
    require(off + 8 + blen == len(data), "trailing bytes after the BIN chunk")
    require("uri" not in doc["buffers"][0], "GLB buffer 0 must not have a uri")
    return doc, data[off + 8:off + 8 + blen]


def check_gltf(path, vertices, triangles):
    doc, buf = load_gltf(path)
    require(doc["asset"]["version"] == "2.0", "asset.version")
    require(len(doc["buffers"]) == 1, "one buffer expected")
    require(doc["buffers"][0]["byteLength"] <= len(buf), "buffer shorter than byteLength")
    values = []
    for i, acc in enumerate(doc["accessors"]):
        view = doc["bufferViews"][acc["bufferView"]]
        comp = GLTF_COMPONENTS[acc["componentType"]]
        n = GLTF_TYPES[acc["type"]]
        size = struct.calcsize("<" + comp)
        require(acc["count"] >= 1, "accessor %d: count < 1" % i)
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        require(start % size == 0, "accessor %d misaligned" % i)
        end = start + acc["count"] * n * size
        require(view.get("byteOffset", 0) + view["byteLength"] <= doc["buffers"][0]["byteLength"],
                "bufferView beyond its buffer")
        require(end <= view.get("byteOffset", 0) + view["byteLength"],
                "accessor %d beyond its bufferView" % i)
        v = struct.unpack_from("<%d%s" % (acc["count"] * n, comp), buf, start)
        cols = [v[c::n] for c in range(n)]
        for key, fn in (("min", min), ("max", max)):
            if key in acc:
                actual = [fn(c) for c in cols]
                declared = acc[key]
                if comp == "f":  # compare as float32, which the data is
                    declared = list(struct.unpack("<%df" % n, struct.pack("<%df" % n, *declared)))
                require(declared == actual, "accessor %d %s %r, data %r" % (i, key, acc[key], actual))
        values.append(v)
    prim = doc["meshes"][0]["primitives"][0]
    require(prim.get("mode", 4) == 4, "primitive mode is not TRIANGLES")
    pos = doc["accessors"][prim["attributes"]["POSITION"]]
    require(pos["type"] == "VEC3" and pos["componentType"] == 5126, "POSITION must be float VEC3")
    require("min" in pos and "max" in pos, "POSITION needs min and max")
    require(pos["count"] == vertices, "POSITION count %d, expected %d" % (pos["count"], vertices))
    for name, a in prim["attributes"].items():
        require(doc["accessors"][a]["count"] == pos["count"], "attribute %s count" % name)
    idx = prim["indices"]
    require(doc["accessors"][idx]["count"] == 3 * triangles,
            "%d indices, expected %d" % (doc["accessors"][idx]["count"], 3 * triangles))
    require(all(i < pos["count"] for i in values[idx]), "index beyond POSITION count")
    return "%d vertices, %d triangles, %d attributes" % (pos["count"], triangles,
                                                         len(prim["attributes"]))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("kind", choices=["vtu", "obj", "gltf"])
    ap.add_argument("file")
    ap.add_argument("--vertices", type=int, required=True)
    ap.add_argument("--cells", type=int)
    ap.add_argument("--triangles", type=int)
    a = ap.parse_args()
    try:
        if a.kind == "vtu":
            msg = check_vtu(a.file, a.vertices, a.cells)
        elif a.kind == "obj":
            msg = check_obj(a.file, a.vertices, a.triangles)
        else:
            msg = check_gltf(a.file, a.vertices, a.triangles)
    except (Invalid, ET.ParseError, ValueError, KeyError, IndexError, struct.error) as e:
        print("%s: invalid %s: %s" % (a.file, a.kind, e), file=sys.stderr)
        return 1
    print("%s: valid %s (%s)" % (a.file, a.kind, msg))
    return 0


if __name__ == "__main__":
    sys.exit(main())
