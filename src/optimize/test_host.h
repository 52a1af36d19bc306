// The optimizer tests' host: a box [0,1] x [0,1] x [0,h] with h = 1 + x0 / 2, meshed with
// cubes x cubes x cubes cubes of 6 tets (2 by default), K = 2..5 parameters in [0,1], and
// closed-form fields:
//   q (per vertex) = 1 + sum_d (x_d - t_d)^2 + z,   s (per tet) = 1 + x1 / 2 + z_centroid,
// regions "bottom" (z = 0) and "top" (z = h). Its integrals are known in closed form:
//   integral(q) = h (1 + sum_d (x_d - t_d)^2 + h / 2),   region_integral(q, top) = 1 + sum + h
// so the minimizers are known. Its scalar outputs are the same closed forms, computed by the
// host on each sample as a CAD host computes a B-rep quantity: "brep_volume" = h (the box's
// exact volume) and "exact_integral_q" = integral(q). With fail_corner the host fails where x0 >
// 0.75 and x1 > 0.75. Written against the builder's public C ABI (cadinterp_builder.h) only.
#pragma once

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "cadinterp/cadinterp_builder.h"

namespace cadinterp::optimize::test {

struct BoxHost {
  int K;
  std::array<double, 5> target;
  bool fail_corner = false;
  std::vector<cadinterp_parameter_desc> params;
  std::string identity;
  cadinterp_host host{};

  BoxHost(int k, std::array<double, 5> t, bool fail = false, int cubes_per_axis = 2)
      : K(k), target(t), fail_corner(fail), cubes(cubes_per_axis) {
    static const char* names[5] = {"height", "a", "b", "c", "d"};
    for (int d = 0; d < K; ++d) params.push_back({names[d], "1", 0.0, 1.0});
    identity = "optimize test box K=" + std::to_string(K) + (fail ? " fail" : "") +
               (cubes == 2 ? "" : " cubes=" + std::to_string(cubes));
    for (double v : t) identity += " " + std::to_string(v);
    host.struct_size = sizeof host;
    host.name = "optimize test box";
    host.identity = identity.c_str();
    host.parameter_count = K;
    host.parameters = params.data();
    host.user = this;
    host.regenerate = &regenerate;
    host.references = &references;
    host.simulate = &simulate;
    host.thread_safe = 1;
  }

  static double height(const double* x) { return 1.0 + 0.5 * x[0]; }
  double misfit(const double* x) const {
    double s = 0.0;
    for (int d = 0; d < K; ++d)
      s += (x[d] - target[static_cast<std::size_t>(d)]) *
           (x[d] - target[static_cast<std::size_t>(d)]);
    return s;
  }
  // The closed forms of the header comment.
  double integral_q(const double* x) const {
    const double h = height(x);
    return h * (1.0 + misfit(x) + 0.5 * h);
  }
  double top_integral_q(const double* x) const { return 1.0 + misfit(x) + height(x); }

  int cubes = 2;  // per axis: 6 cubes^3 tets (the benchmark's mesh is finer)
  int vid(int i, int j, int k) const { return (k * (cubes + 1) + j) * (cubes + 1) + i; }

  static cadinterp_status regenerate(void* user, const double* x, cadinterp_sample* out) {
    const auto* h = static_cast<const BoxHost*>(user);
    if (h->fail_corner && x[0] > 0.75 && x[1] > 0.75) {
      cadinterp_sample_set_message(out, "corner fails");
      return CADINTERP_E_INFEASIBLE;
    }
    const int kN = h->cubes;
    std::vector<double> v;
    for (int k = 0; k <= kN; ++k)
      for (int j = 0; j <= kN; ++j)
        for (int i = 0; i <= kN; ++i) {
          v.push_back(double(i) / kN);
          v.push_back(double(j) / kN);
          v.push_back(height(x) * k / kN);
        }
    std::vector<uint32_t> tets, tris;
    std::vector<int32_t> tags;
    // Six tets per cube around the diagonal c0-c7 (all positively oriented).
    static const int kTets[6][4] = {{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7},
                                    {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}};
    for (int k = 0; k < kN; ++k)
      for (int j = 0; j < kN; ++j)
        for (int i = 0; i < kN; ++i) {
          uint32_t c[8];
          for (int b = 0; b < 8; ++b)
            c[b] =
                static_cast<uint32_t>(h->vid(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1)));
          for (const auto& t : kTets)
            for (int q = 0; q < 4; ++q) tets.push_back(c[t[q]]);
        }
    // Boundary triangles: bottom (tag 0, outward -z) and top (tag 1, +z), sides (tag 2).
    auto quad = [&](uint32_t a, uint32_t b, uint32_t c, uint32_t d, int32_t tag) {
      const uint32_t q[6] = {a, b, c, a, c, d};
      tris.insert(tris.end(), q, q + 6);
      tags.push_back(tag);
      tags.push_back(tag);
    };
    for (int j = 0; j < kN; ++j)
      for (int i = 0; i < kN; ++i) {
        quad(h->vid(i, j, 0), h->vid(i, j + 1, 0), h->vid(i + 1, j + 1, 0), h->vid(i + 1, j, 0), 0);
        quad(h->vid(i, j, kN), h->vid(i + 1, j, kN), h->vid(i + 1, j + 1, kN), h->vid(i, j + 1, kN),
             1);
      }
    for (int k = 0; k < kN; ++k)
      for (int s = 0; s < kN; ++s) {
        quad(h->vid(s, 0, k), h->vid(s + 1, 0, k), h->vid(s + 1, 0, k + 1), h->vid(s, 0, k + 1), 2);
        quad(h->vid(s, kN, k), h->vid(s, kN, k + 1), h->vid(s + 1, kN, k + 1), h->vid(s + 1, kN, k),
             2);
        quad(h->vid(0, s, k), h->vid(0, s, k + 1), h->vid(0, s + 1, k + 1), h->vid(0, s + 1, k), 2);
        quad(h->vid(kN, s, k), h->vid(kN, s + 1, k), h->vid(kN, s + 1, k + 1), h->vid(kN, s, k + 1),
             2);
      }
    return cadinterp_sample_set_mesh(out, v.data(), v.size() / 3, tets.data(), tets.size() / 4,
                                     tris.data(), tags.data(), tags.size());
  }
  static cadinterp_status references(void*, const double*, cadinterp_sample* out) {
    const int32_t bottom[1] = {0}, top[1] = {1};
    cadinterp_status s = cadinterp_sample_add_region(out, "bottom", "fixed", bottom, 1);
    if (s == CADINTERP_OK) s = cadinterp_sample_add_region(out, "top", "force", top, 1);
    return s;
  }
  static cadinterp_status simulate(void* user, const double* x, const cadinterp_host_mesh* m,
                                   cadinterp_sample* out) {
    const auto* h = static_cast<const BoxHost*>(user);
    std::vector<double> q(m->vertex_count), s(m->tet_count);
    for (std::size_t v = 0; v < m->vertex_count; ++v)
      q[v] = 1.0 + h->misfit(x) + m->vertices[3 * v + 2];
    for (std::size_t t = 0; t < m->tet_count; ++t) {
      double z = 0.0;
      for (int c = 0; c < 4; ++c) z += 0.25 * m->vertices[3 * m->tets[4 * t + c] + 2];
      s[t] = 1.0 + 0.5 * x[1] + z;
    }
    cadinterp_status st =
        cadinterp_sample_add_field(out, "q", CADINTERP_PER_VERTEX, 1, q.data(), q.size());
    if (st == CADINTERP_OK)
      st = cadinterp_sample_add_field(out, "s", CADINTERP_PER_TET, 1, s.data(), s.size());
    if (st == CADINTERP_OK) st = cadinterp_sample_add_output(out, "brep_volume", height(x), "1");
    if (st == CADINTERP_OK)
      st = cadinterp_sample_add_output(out, "exact_integral_q", h->integral_q(x), nullptr);
    return st;
  }

  // Builds the asset at `path`; returns the builder's message, "" on success, and its report.
  std::string build(const std::string& path, int degree, int max_samples,
                    cadinterp_build_report* report) const {
    cadinterp_build_options o;
    cadinterp_build_options_init(&o);
    o.degree = degree;
    o.geometry_tolerance = 1e-3;
    o.field_tolerance = 2e-3;
    o.max_samples = max_samples;
    o.max_depth = 5;
    o.threads = 1;
    cadinterp_builder* b = nullptr;
    if (cadinterp_builder_create(&host, &o, &b) != CADINTERP_OK)
      return cadinterp_builder_create_error();
    const cadinterp_status s = cadinterp_builder_run(b, path.c_str());
    report->struct_size = sizeof *report;
    cadinterp_builder_report(b, report);
    std::string error = s == CADINTERP_OK ? "" : std::string(cadinterp_builder_error(b)) + " ";
    cadinterp_builder_destroy(b);
    return error;
  }
};

}  // namespace cadinterp::optimize::test
