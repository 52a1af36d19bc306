/* The models behind the host: options, the parameter box and its fail region, and dispatch to
 * analytic_bracket.c / analytic_plate.c. No global mutable state: a model is immutable once
 * created, and every evaluation works on its own stack and heap memory. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "analytic_internal.h"

#define DEFAULT_CELLS 4
#define DEFAULT_EDGE_UM 5000L
#define DEFAULT_LEVELS 2

typedef struct model_class {
  const char* name;
  int parameter_count;
  const cadinterp_parameter_desc* parameters;
  int field_count;
  const analytic_field_desc* fields;
  int region_count;
  const analytic_region* regions;
} model_class;

static const model_class kClasses[3] = {
    {"bracket", 4, analytic_bracket_parameters, 2, analytic_bracket_fields, 2,
     analytic_bracket_regions},
    {"plate", 3, analytic_plate_parameters, 3, analytic_plate_fields, 2, analytic_plate_regions},
    {"foldplate", 4, analytic_foldplate_parameters, 3, analytic_plate_fields, 2,
     analytic_plate_regions}};

/* ---- options ---- */

static int key_is(const char* key, size_t length, const char* name) {
  return strlen(name) == length && strncmp(key, name, length) == 0;
}

/* Non-negative integer of 1..9 digits, the whole of [s, s + length). */
static int parse_int(const char* s, size_t length, long* out) {
  long v = 0;
  size_t i;
  if (length == 0 || length > 9) return 0;
  for (i = 0; i < length; ++i) {
    if (s[i] < '0' || s[i] > '9') return 0;
    v = 10 * v + (s[i] - '0');
  }
  *out = v;
  return 1;
}

/* Millimetres with up to 3 decimals, to micrometres. Parsed by hand rather than by strtod, whose
 * decimal point follows the process locale: the identity must not. */
static int parse_mm(const char* s, size_t length, long* out_um) {
  const char* dot = memchr(s, '.', length);
  long whole, frac = 0;
  size_t i, digits;
  if (!dot) {
    if (!parse_int(s, length, &whole)) return 0;
    *out_um = whole * 1000;
    return 1;
  }
  if (!parse_int(s, (size_t)(dot - s), &whole)) return 0;
  digits = length - (size_t)(dot - s) - 1;
  if (digits == 0 || digits > 3 || !parse_int(dot + 1, digits, &frac)) return 0;
  for (i = digits; i < 3; ++i) frac *= 10;
  *out_um = whole * 1000 + frac;
  return 1;
}

/* Parses `options` into m; returns NULL or a static message. */
static const char* parse_options(const char* options, analytic_model* m) {
  const char* p = options;
  unsigned seen = 0;
  if (!options || !*options) return NULL;
  for (;;) {
    const char* end = strchr(p, ',');
    const char* eq;
    size_t length = end ? (size_t)(end - p) : strlen(p), key_length, value_length;
    const char* value;
    long v;
    unsigned bit;
    eq = memchr(p, '=', length);
    if (!eq || eq == p) return "analytic host: options must be key=value pairs separated by ','";
    key_length = (size_t)(eq - p);
    value = eq + 1;
    value_length = length - key_length - 1;
    if (key_is(p, key_length, "cells") && m->kind == ANALYTIC_BRACKET) {
      if (!parse_int(value, value_length, &v) || v < 1 || v > 64)
        return "analytic host: cells must be an integer in 1..64";
      m->cells = (int)v;
      bit = 1;
    } else if (key_is(p, key_length, "edge") && m->kind != ANALYTIC_BRACKET) {
      if (!parse_mm(value, value_length, &v) || v < 500 || v > 100000)
        return "analytic host: edge must be a length in mm in 0.5..100 with at most 3 decimals";
      m->edge_um = v;
      bit = 2;
    } else if (key_is(p, key_length, "levels")) {
      if (!parse_int(value, value_length, &v) || v > 6)
        return "analytic host: levels must be an integer in 0..6";
      m->levels = (int)v;
      bit = 4;
    } else if (key_is(p, key_length, "fail_region")) {
      if (!parse_int(value, value_length, &v) || v > 2)
        return "analytic host: fail_region must be 0, 1 or 2";
      m->fail_region = (int)v;
      bit = 8;
    } else if (key_is(p, key_length, "sleep_ms")) {
      if (!parse_int(value, value_length, &v) || v > 3600000)
        return "analytic host: sleep_ms must be an integer in 0..3600000";
      m->sleep_ms = v;
      bit = 16;
    } else if (key_is(p, key_length, "kill_after")) {
      if (!parse_int(value, value_length, &v))
        return "analytic host: kill_after must be an integer in 0..999999999";
      m->kill_after = v;
      bit = 32;
    } else {
      return m->kind == ANALYTIC_BRACKET
                 ? "analytic host: unknown option for model 'bracket' (known: cells, levels, "
                   "fail_region, sleep_ms, kill_after)"
                 : "analytic host: unknown option for model 'plate' or 'foldplate' (known: "
                   "edge, levels, fail_region, sleep_ms, kill_after)";
    }
    if (seen & bit) return "analytic host: an option is given twice";
    seen |= bit;
    if (!end) return NULL;
    p = end + 1;
  }
}

analytic_model* analytic_model_create(const char* model, const char* options, const char** error) {
  analytic_model m;
  const char* message;
  analytic_model* out;
  memset(&m, 0, sizeof(m));
  if (!model || !*model || strcmp(model, "bracket") == 0) {
    m.kind = ANALYTIC_BRACKET;
  } else if (strcmp(model, "plate") == 0) {
    m.kind = ANALYTIC_PLATE;
  } else if (strcmp(model, "foldplate") == 0) {
    m.kind = ANALYTIC_FOLDPLATE;
  } else {
    if (error) *error = "analytic host: unknown model (known: bracket, plate, foldplate)";
    return NULL;
  }
  m.cells = DEFAULT_CELLS;
  m.edge_um = DEFAULT_EDGE_UM;
  m.levels = DEFAULT_LEVELS;
  m.kill_after = -1;
  message = parse_options(options, &m);
  if (message) {
    if (error) *error = message;
    return NULL;
  }
  /* Integers only, so that the identity does not depend on the locale or on float printing. */
  if (m.kind == ANALYTIC_BRACKET)
    snprintf(m.identity, sizeof(m.identity),
             "analytic bracket v1 (cells=%d, levels=%d, fail_region=%d)", m.cells, m.levels,
             m.fail_region);
  else
    snprintf(m.identity, sizeof(m.identity),
             "analytic %s v1 (edge=%ld um, levels=%d, fail_region=%d)",
             m.kind == ANALYTIC_PLATE ? "plate" : "foldplate", m.edge_um, m.levels, m.fail_region);
  out = (analytic_model*)malloc(sizeof(*out));
  if (!out) {
    if (error) *error = "analytic host: out of memory";
    return NULL;
  }
  *out = m;
  return out;
}

void analytic_model_destroy(analytic_model* model) { free(model); }

const char* analytic_model_name(const analytic_model* model) { return kClasses[model->kind].name; }

const char* analytic_model_identity(const analytic_model* model) { return model->identity; }

int analytic_model_parameter_count(const analytic_model* model) {
  return kClasses[model->kind].parameter_count;
}

const cadinterp_parameter_desc* analytic_model_parameters(const analytic_model* model) {
  return kClasses[model->kind].parameters;
}

int analytic_model_region_count(const analytic_model* model) {
  return kClasses[model->kind].region_count;
}

const analytic_region* analytic_model_region(const analytic_model* model, int i) {
  const model_class* c = &kClasses[model->kind];
  return i >= 0 && i < c->region_count ? &c->regions[i] : NULL;
}

int analytic_model_field_count(const analytic_model* model) {
  return kClasses[model->kind].field_count;
}

const analytic_field_desc* analytic_model_field(const analytic_model* model, int i) {
  const model_class* c = &kClasses[model->kind];
  return i >= 0 && i < c->field_count ? &c->fields[i] : NULL;
}

/* ---- the parameter box ---- */

/* x inside the box; a relative slack of 1e-9 absorbs the rounding of box corners computed by
 * the caller (lower + (upper - lower) * 1.0). */
static int inside_box(const analytic_model* model, const double* x) {
  const model_class* c = &kClasses[model->kind];
  int i;
  if (!x) return 0;
  for (i = 0; i < c->parameter_count; ++i) {
    const double lo = c->parameters[i].lower, hi = c->parameters[i].upper;
    const double slack = 1e-9 * (hi - lo);
    if (!isfinite(x[i]) || x[i] < lo - slack || x[i] > hi + slack) return 0;
  }
  return 1;
}

int analytic_model_in_fail_region(const analytic_model* model, const double* x) {
  const cadinterp_parameter_desc* p;
  double u[2];
  int i;
  if (!model || !x || !model->fail_region) return 0;
  p = kClasses[model->kind].parameters;
  for (i = 0; i < 2; ++i) u[i] = (x[i] - p[i].lower) / (p[i].upper - p[i].lower);
  /* 1: the corner where the first two parameters are both in the top quarter of their range
   * (1/16 of the box, bounded by dyadic planes). 2: a quarter disk of normalised radius
   * sqrt(0.64 / pi) around that corner (16 % of the box, a curved boundary no split follows). */
  if (model->fail_region == 1) return u[0] > 0.75 && u[1] > 0.75;
  return (1 - u[0]) * (1 - u[0]) + (1 - u[1]) * (1 - u[1]) < 0.64 / 3.14159265358979323846;
}

static cadinterp_status check_x(const analytic_model* model, const double* x,
                                const char** message) {
  if (!inside_box(model, x)) {
    if (message) *message = "analytic host: x is not finite or outside the parameter box";
    return CADINTERP_E_OUTSIDE_DOMAIN;
  }
  if (analytic_model_in_fail_region(model, x)) {
    if (message)
      *message = model->kind == ANALYTIC_BRACKET
                     ? (model->fail_region == 1
                            ? "analytic bracket: infeasible by request (fail_region=1: length "
                              "and height both in the top quarter of their ranges)"
                            : "analytic bracket: infeasible by request (fail_region=2: length "
                              "and height near the top of their ranges)")
                     : (model->fail_region == 1
                            ? "analytic plate/foldplate: infeasible by request (fail_region=1: "
                              "length and width both in the top quarter of their ranges)"
                            : "analytic plate/foldplate: infeasible by request (fail_region=2: "
                              "length and width near the top of their ranges)");
    return CADINTERP_E_INFEASIBLE;
  }
  return CADINTERP_OK;
}

/* ---- dispatch ---- */

static void shape_at(const analytic_model* model, const double* x, analytic_shape* s) {
  memset(s, 0, sizeof(*s));
  s->kind = model->kind;
  if (model->kind == ANALYTIC_BRACKET)
    analytic_bracket_shape(model, x, s);
  else if (model->kind == ANALYTIC_PLATE)
    analytic_plate_shape(model, x, s);
  else
    analytic_foldplate_shape(model, x, s);
}

void analytic_shape_position(const analytic_shape* s, const int ijk[3], double p[3]) {
  if (s->kind == ANALYTIC_BRACKET)
    analytic_bracket_position(s, ijk, p);
  else if (s->kind == ANALYTIC_PLATE)
    analytic_plate_position(s, ijk, p);
  else
    analytic_foldplate_position(s, ijk, p);
}

int32_t analytic_shape_face_tag(const analytic_shape* s, int axis, int side, const int cell[3]) {
  return s->kind == ANALYTIC_BRACKET ? analytic_bracket_face_tag(s, axis, side, cell)
                                     : analytic_plate_face_tag(s, axis, side, cell);
}

int32_t analytic_shape_triangle_tag(const analytic_shape* s, int axis, int side, const int cell[3],
                                    int half) {
  return s->kind == ANALYTIC_FOLDPLATE ? analytic_foldplate_triangle_tag(s, axis, side, cell, half)
                                       : analytic_shape_face_tag(s, axis, side, cell);
}

static void shape_field_at(const analytic_shape* s, int field, const double p[3], double* value) {
  if (s->kind == ANALYTIC_BRACKET)
    analytic_bracket_field_at(s, field, p, value);
  else
    analytic_plate_field_at(s, field, p, value);
}

/* ---- evaluation ---- */

cadinterp_status analytic_model_mesh(const analytic_model* model, const double* x,
                                     analytic_mesh* out, const char** message) {
  analytic_shape s;
  cadinterp_status status;
  if (!model || !out) return CADINTERP_E_INVALID_ARGUMENT;
  status = check_x(model, x, message);
  if (status != CADINTERP_OK) return status;
  shape_at(model, x, &s);
  status = analytic_shape_mesh(&s, out);
  if (status != CADINTERP_OK && message) *message = "analytic host: out of memory";
  return status;
}

cadinterp_status analytic_model_references(const analytic_model* model, const double* x,
                                           analytic_references* out, const char** message) {
  analytic_shape s;
  analytic_mesh mesh;
  cadinterp_status status;
  if (!model || !out) return CADINTERP_E_INVALID_ARGUMENT;
  status = check_x(model, x, message);
  if (status != CADINTERP_OK) return status;
  shape_at(model, x, &s);
  /* The whole mesh is rebuilt for its vertices: cheap next to what a real kernel does here, and
   * it guarantees the points lie on exactly the mesh regenerate wrote. */
  status = analytic_shape_mesh(&s, &mesh);
  if (status == CADINTERP_OK) {
    status = analytic_shape_references(&s, mesh.vertices, model->levels, out);
    analytic_mesh_free(&mesh);
  }
  if (status != CADINTERP_OK && message) *message = "analytic host: out of memory";
  return status;
}

cadinterp_status analytic_model_field_values(const analytic_model* model, int field,
                                             const double* x, const cadinterp_host_mesh* mesh,
                                             double* values, const char** message) {
  const analytic_field_desc* desc;
  analytic_shape s;
  cadinterp_status status;
  size_t i;
  if (!model || !mesh || !values || !(desc = analytic_model_field(model, field))) {
    if (message) *message = "analytic host: invalid field evaluation arguments";
    return CADINTERP_E_INVALID_ARGUMENT;
  }
  status = check_x(model, x, message);
  if (status != CADINTERP_OK) return status;
  shape_at(model, x, &s);
  if (desc->location == CADINTERP_PER_VERTEX) {
    for (i = 0; i < mesh->vertex_count; ++i)
      shape_field_at(&s, field, &mesh->vertices[3 * i], &values[(size_t)desc->components * i]);
  } else {
    for (i = 0; i < mesh->tet_count; ++i) {
      double centroid[3] = {0.0, 0.0, 0.0};
      int k, c;
      for (k = 0; k < 4; ++k)
        for (c = 0; c < 3; ++c) centroid[c] += 0.25 * mesh->vertices[3 * mesh->tets[4 * i + k] + c];
      shape_field_at(&s, field, centroid, &values[(size_t)desc->components * i]);
    }
  }
  return CADINTERP_OK;
}

cadinterp_status analytic_model_field_at(const analytic_model* model, int field, const double* x,
                                         const double* p, double* value) {
  analytic_shape s;
  if (!model || !p || !value || !analytic_model_field(model, field))
    return CADINTERP_E_INVALID_ARGUMENT;
  if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) return CADINTERP_E_INVALID_ARGUMENT;
  if (!inside_box(model, x)) return CADINTERP_E_OUTSIDE_DOMAIN;
  shape_at(model, x, &s);
  shape_field_at(&s, field, p, value);
  return CADINTERP_OK;
}
