#include "core/faces.h"

#include <algorithm>

namespace cadinterp::core {

std::vector<SharedFace> shared_faces(const KdTree& tree) {
  const int K = tree.dim();
  std::vector<SharedFace> out;
  std::vector<int> touching;
  for (int a : tree.leaves()) {
    const KdTree::Node& na = tree.node(a);
    touching.clear();
    tree.leaves_touching(na.box, touching);
    for (int b : touching) {
      const KdTree::Node& nb = tree.node(b);
      for (int d = 0; d < K; ++d) {
        if (na.box.hi[d] != nb.box.lo[d]) continue;
        SharedFace f{a, b, d, {}, false};
        bool full = true;  // positive measure in every other direction
        for (int e = 0; e < K; ++e) {
          f.box.lo[e] = std::max(na.box.lo[e], nb.box.lo[e]);
          f.box.hi[e] = std::min(na.box.hi[e], nb.box.hi[e]);
          if (e != d && f.box.lo[e] >= f.box.hi[e]) full = false;
          if (e != d && na.level[e] != nb.level[e]) f.t_junction = true;
        }
        if (full) out.push_back(f);
      }
    }
  }
  std::sort(out.begin(), out.end(), [](const SharedFace& x, const SharedFace& y) {
    return x.lower != y.lower ? x.lower < y.lower : x.upper < y.upper;
  });
  return out;
}

}  // namespace cadinterp::core
