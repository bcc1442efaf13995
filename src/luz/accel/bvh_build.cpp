// Binned SAH BVH construction (Wald 2007, "On fast construction of SAH-based
// bounding volume hierarchies"), parallel with TBB: large nodes are binned in
// parallel, and the two subtrees of every node above a size threshold are
// built as parallel tasks. The tree is built into a scratch array of inner
// nodes, then laid out depth-first in Aila & Laine's two-box node format.
#include "luz/accel/bvh_build.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <stdexcept>

namespace luz {

namespace {

struct Aabb {
  Vec3 lo{kInfinity, kInfinity, kInfinity}, hi{-kInfinity, -kInfinity, -kInfinity};
  void grow(Vec3 p) {
    lo = vmin(lo, p);
    hi = vmax(hi, p);
  }
  void grow(const Aabb& b) {
    lo = vmin(lo, b.lo);
    hi = vmax(hi, b.hi);
  }
  bool empty() const { return !(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z); }
  // Half the surface area (the SAH only uses ratios).
  float half_area() const {
    if (empty()) return 0.f;
    Vec3 e = hi - lo;
    return e.x * e.y + e.y * e.z + e.z * e.x;
  }
};

// A primitive during the build: its box and tagged id. 32 bytes, partitioned
// in place so that every leaf ends up a contiguous range.
struct PrimRef {
  Vec3 lo;
  uint32_t id;
  Vec3 hi;
  uint32_t pad;
  Vec3 centroid2() const { return lo + hi; }  // twice the box centre
};

struct TmpNode {
  Aabb box[2];
  uint32_t child[2];  // bvh.h child reference; inner children index tmp nodes
};

constexpr int kMaxBins = 32;
constexpr size_t kParallelBinning = 1 << 15;  // bin nodes this large in parallel
constexpr size_t kParallelSubtree = 1 << 11;  // build subtrees this large as tasks

struct Bin {
  Aabb box;  // bounds of the primitive boxes that fell in
  uint32_t count = 0;
};

struct Bins {
  int nb = 0;
  Bin b[3][kMaxBins];
  explicit Bins(int bins = 0) : nb(bins) {}
  void merge(const Bins& o) {
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < nb; ++i) {
        b[a][i].box.grow(o.b[a][i].box);
        b[a][i].count += o.b[a][i].count;
      }
  }
};

// Which bin centroid c falls into along axis a: the one function used both
// to bin and to partition, so the two always agree.
struct Binner {
  int nb;
  Vec3 cmin, scale;  // scale[a] = 0 where the centroids have no extent
  Binner(const Aabb& cb, int bins) : nb(bins), cmin(cb.lo) {
    for (int a = 0; a < 3; ++a) {
      float ext = cb.hi[a] - cb.lo[a];
      scale[a] = ext > 0.f ? float(bins) * (1.f - 1e-6f) / ext : 0.f;
    }
  }
  int bin(Vec3 c, int a) const {
    float f = (c[a] - cmin[a]) * scale[a];
    int i = int(max(f, 0.f));  // max() sends NaN to 0
    return i < nb ? i : nb - 1;
  }
};

int ceil_log2(size_t n) {
  int k = 0;
  while ((size_t(1) << k) < n) ++k;
  return k;
}

class Builder {
 public:
  Builder(std::vector<PrimRef>& refs, const BvhBuildOptions& opt) : refs_(refs), opt_(opt) {
    nodes_.resize(std::max<size_t>(refs.size(), 1));
    nb_ = std::clamp(opt.bins, 2, kMaxBins);
    max_leaf_ = std::clamp<uint32_t>(opt.max_leaf_size, 1, kBvhMaxLeafSize);
  }

  // Builds the whole tree; returns the scratch nodes (root = index 0).
  std::vector<TmpNode> run() {
    size_t n = refs_.size();
    Aabb box, cbox;
    compute_bounds(0, n, box, cbox);
    uint32_t root = alloc();
    if (n == 1) {
      // One primitive: a root whose second child is an empty leaf.
      nodes_[root].box[0] = nodes_[root].box[1] = box;
      nodes_[root].child[0] = bvh_make_leaf(0, 1);
      nodes_[root].child[1] = bvh_make_leaf(0, 0);
    } else {
      split_node(root, 0, n, cbox, 1);
    }
    nodes_.resize(next_.load());
    return std::move(nodes_);
  }

 private:
  std::vector<PrimRef>& refs_;
  const BvhBuildOptions& opt_;
  std::vector<TmpNode> nodes_;
  std::atomic<uint32_t> next_{0};
  int nb_;
  uint32_t max_leaf_;

  uint32_t alloc() { return next_.fetch_add(1, std::memory_order_relaxed); }

  void compute_bounds(size_t b, size_t e, Aabb& box, Aabb& cbox) const {
    for (size_t i = b; i < e; ++i) {
      box.grow(Aabb{refs_[i].lo, refs_[i].hi});
      cbox.grow(refs_[i].centroid2());
    }
  }

  Aabb centroid_bounds(size_t b, size_t e) const {
    if (e - b < kParallelBinning) {
      Aabb cb;
      for (size_t i = b; i < e; ++i) cb.grow(refs_[i].centroid2());
      return cb;
    }
    return tbb::parallel_reduce(
        tbb::blocked_range<size_t>(b, e, 8192), Aabb{},
        [&](const tbb::blocked_range<size_t>& r, Aabb acc) {
          for (size_t i = r.begin(); i != r.end(); ++i) acc.grow(refs_[i].centroid2());
          return acc;
        },
        [](Aabb x, const Aabb& y) {
          x.grow(y);
          return x;
        });
  }

  void bin_range(const Binner& bn, size_t b, size_t e, Bins& bins) const {
    for (size_t i = b; i < e; ++i) {
      const PrimRef& r = refs_[i];
      Vec3 c = r.centroid2();
      Aabb rb{r.lo, r.hi};
      for (int a = 0; a < 3; ++a) {
        Bin& x = bins.b[a][bn.bin(c, a)];
        x.box.grow(rb);
        ++x.count;
      }
    }
  }

  // A split of refs_[b, e) at `mid`, with both sides' bounds.
  struct Split {
    size_t mid;
    Aabb lbox, lcbox, rbox, rcbox;
  };

  // Object median along the widest centroid axis (the fallback, the depth
  // guard and the baseline builder).
  Split median_split(size_t b, size_t e, const Aabb& cbox) {
    Vec3 ext = cbox.hi - cbox.lo;
    int axis = ext.x >= ext.y ? (ext.x >= ext.z ? 0 : 2) : (ext.y >= ext.z ? 1 : 2);
    size_t mid = b + (e - b) / 2;
    if (ext[axis] > 0.f)
      std::nth_element(refs_.begin() + b, refs_.begin() + mid, refs_.begin() + e,
                       [axis](const PrimRef& x, const PrimRef& y) { return x.centroid2()[axis] < y.centroid2()[axis]; });
    Split s;
    s.mid = mid;
    compute_bounds(b, mid, s.lbox, s.lcbox);
    compute_bounds(mid, e, s.rbox, s.rcbox);
    return s;
  }

  // Best binned-SAH split of refs_[b, e), or false when making a leaf is no
  // more expensive (only allowed for ≤ max_leaf primitives) — then `leaf`.
  bool sah_split(size_t b, size_t e, const Aabb& cbox, bool may_leaf, Split& s, bool& leaf) {
    size_t n = e - b;
    leaf = false;
    // Small nodes: no more bins than primitives (the sweep and the bins'
    // initialisation would otherwise dominate near the leaves).
    int nb = int(std::min<size_t>(size_t(nb_), std::max<size_t>(n, 4)));
    Binner bn(cbox, nb);
    if (bn.scale.x == 0.f && bn.scale.y == 0.f && bn.scale.z == 0.f) {
      // All centroids coincide: no plane separates them.
      if (may_leaf) return leaf = true, false;
      s = median_split(b, e, cbox);
      return true;
    }
    Bins bins(nb);
    if (n >= kParallelBinning) {
      bins = tbb::parallel_reduce(
          tbb::blocked_range<size_t>(b, e, 8192), Bins(nb),
          [&](const tbb::blocked_range<size_t>& r, Bins acc) {
            bin_range(bn, r.begin(), r.end(), acc);
            return acc;
          },
          [&](Bins x, const Bins& y) {
            x.merge(y);
            return x;
          });
    } else {
      bin_range(bn, b, e, bins);
    }
    // Sweep: cost of splitting after bin i on each axis.
    float best = kInfinity, parent_area = 0.f;
    int best_axis = -1, best_bin = -1;
    float right_area[kMaxBins];
    uint32_t right_count[kMaxBins];
    Aabb pbox;
    for (int i = 0; i < nb; ++i) pbox.grow(bins.b[0][i].box);
    parent_area = pbox.half_area();
    for (int a = 0; a < 3; ++a) {
      if (bn.scale[a] == 0.f) continue;
      const Bin* x = bins.b[a];
      Aabb acc;
      uint32_t cnt = 0;
      for (int i = nb - 1; i > 0; --i) {
        acc.grow(x[i].box);
        cnt += x[i].count;
        right_area[i] = acc.half_area();
        right_count[i] = cnt;
      }
      acc = Aabb{};
      cnt = 0;
      for (int i = 0; i < nb - 1; ++i) {
        acc.grow(x[i].box);
        cnt += x[i].count;
        uint32_t rc = right_count[i + 1];
        if (cnt == 0 || rc == 0) continue;
        float c = acc.half_area() * float(cnt) + right_area[i + 1] * float(rc);
        if (c < best) best = c, best_axis = a, best_bin = i;
      }
    }
    if (best_axis < 0) {
      // Every axis put all centroids into one bin (extreme clustering).
      if (may_leaf) return leaf = true, false;
      s = median_split(b, e, cbox);
      return true;
    }
    float split_cost = opt_.traversal_cost + opt_.intersection_cost * best / std::max(parent_area, 1e-30f);
    float leaf_cost = opt_.intersection_cost * float(n);
    if (may_leaf && leaf_cost <= split_cost) return leaf = true, false;

    const Bin* x = bins.b[best_axis];
    for (int i = 0; i <= best_bin; ++i) s.lbox.grow(x[i].box);
    for (int i = best_bin + 1; i < nb; ++i) s.rbox.grow(x[i].box);
    auto it = std::partition(refs_.begin() + b, refs_.begin() + e,
                             [&](const PrimRef& r) { return bn.bin(r.centroid2(), best_axis) <= best_bin; });
    s.mid = size_t(it - refs_.begin());
    s.lcbox = centroid_bounds(b, s.mid);
    s.rcbox = centroid_bounds(s.mid, e);
    return true;
  }

  // Child reference for refs_[b, e): a leaf, or a new inner node.
  uint32_t make_child(size_t b, size_t e, const Aabb& cbox, int depth) {
    size_t n = e - b;
    if (n <= 1) return bvh_make_leaf(uint32_t(b), uint32_t(n));
    // Decide leaf-or-split before allocating a node.
    Split s;
    bool leaf = false;
    bool may_leaf = n <= max_leaf_;
    bool split;
    if (opt_.median_split || depth + ceil_log2(n) >= kBvhStackSize - 2) {
      split = !may_leaf;
      if (split) s = median_split(b, e, cbox);
    } else {
      split = sah_split(b, e, cbox, may_leaf, s, leaf);
    }
    if (!split) return bvh_make_leaf(uint32_t(b), uint32_t(n));
    uint32_t node = alloc();
    fill(node, b, e, s, depth);
    return node;
  }

  // Splits refs_[b, e) for an already allocated node (the root: always split).
  void split_node(uint32_t node, size_t b, size_t e, const Aabb& cbox, int depth) {
    Split s;
    bool leaf = false;
    if (opt_.median_split || depth + ceil_log2(e - b) >= kBvhStackSize - 2)
      s = median_split(b, e, cbox);
    else
      sah_split(b, e, cbox, false, s, leaf);
    fill(node, b, e, s, depth);
  }

  void fill(uint32_t node, size_t b, size_t e, const Split& s, int depth) {
    TmpNode& t = nodes_[node];
    t.box[0] = s.lbox;
    t.box[1] = s.rbox;
    if (e - b >= kParallelSubtree) {
      tbb::parallel_invoke([&] { t.child[0] = make_child(b, s.mid, s.lcbox, depth + 1); },
                           [&] { t.child[1] = make_child(s.mid, e, s.rcbox, depth + 1); });
    } else {
      t.child[0] = make_child(b, s.mid, s.lcbox, depth + 1);
      t.child[1] = make_child(s.mid, e, s.rcbox, depth + 1);
    }
  }
};

// Lays the scratch tree out depth-first (deterministic whatever the task
// schedule was) in the final node format.
struct Flattener {
  const std::vector<TmpNode>& tmp;
  Bvh& out;

  uint32_t emit(uint32_t t, uint32_t depth) {
    uint32_t idx = uint32_t(out.nodes.size());
    out.nodes.emplace_back();
    out.max_depth = std::max(out.max_depth, depth);
    const TmpNode& s = tmp[t];
    uint32_t c[2];
    for (int k = 0; k < 2; ++k) {
      if (bvh_is_leaf(s.child[k])) {
        c[k] = s.child[k];
        if (bvh_leaf_count(c[k]) > 0) ++out.num_leaves;
      } else {
        c[k] = emit(s.child[k], depth + 1);
      }
    }
    BvhNode& n = out.nodes[idx];
    const Aabb &a = s.box[0], &b = s.box[1];
    n.c0_lx = a.lo.x, n.c0_hx = a.hi.x, n.c0_ly = a.lo.y, n.c0_hy = a.hi.y;
    n.c1_lx = b.lo.x, n.c1_hx = b.hi.x, n.c1_ly = b.lo.y, n.c1_hy = b.hi.y;
    n.c0_lz = a.lo.z, n.c0_hz = a.hi.z, n.c1_lz = b.lo.z, n.c1_hz = b.hi.z;
    n.child[0] = c[0];
    n.child[1] = c[1];
    n.pad[0] = n.pad[1] = 0;
    return idx;
  }
};

Aabb child_box(const BvhNode& n, int k) {
  Aabb b;
  if (k == 0) {
    b.lo = {n.c0_lx, n.c0_ly, n.c0_lz};
    b.hi = {n.c0_hx, n.c0_hy, n.c0_hz};
  } else {
    b.lo = {n.c1_lx, n.c1_ly, n.c1_lz};
    b.hi = {n.c1_hx, n.c1_hy, n.c1_hz};
  }
  return b;
}

}  // namespace

Bvh build_bvh(const SceneView& scene, const BvhBuildOptions& options) {
  auto t0 = std::chrono::steady_clock::now();
  Bvh bvh;
  bvh.num_triangles = scene.num_triangles;
  bvh.num_spheres = scene.num_spheres;
  size_t nt = scene.num_triangles, ns = scene.num_spheres, n = nt + ns;
  if (n >= kBvhMaxPrims) throw std::invalid_argument("build_bvh: too many primitives for the BVH's 27-bit leaf offsets");
  if (n == 0) return bvh;

  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    std::vector<PrimRef> refs(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t i = r.begin(); i != r.end(); ++i) {
        PrimRef& p = refs[i];
        p.pad = 0;
        if (i < nt) {
          Vec3 a = scene.positions[scene.indices[3 * i]], b = scene.positions[scene.indices[3 * i + 1]],
               c = scene.positions[scene.indices[3 * i + 2]];
          p.lo = vmin(a, vmin(b, c));
          p.hi = vmax(a, vmax(b, c));
          p.id = uint32_t(i);
        } else {
          const Sphere& s = scene.spheres[i - nt];
          // A few ulps of slack for intersect_sphere's rounding near tangents.
          float m = max(fabsf(s.center.x), max(fabsf(s.center.y), fabsf(s.center.z))) + fabsf(s.radius);
          float r = fabsf(s.radius) + m * 0x1p-20f;
          p.lo = s.center - Vec3{r, r, r};
          p.hi = s.center + Vec3{r, r, r};
          p.id = uint32_t(i - nt) | kBvhSphereBit;
        }
      }
    });
    Builder builder(refs, options);
    std::vector<TmpNode> tmp = builder.run();
    bvh.nodes.reserve(tmp.size());
    Flattener{tmp, bvh}.emit(0, 1);
    bvh.prims.resize(n);
    for (size_t i = 0; i < n; ++i) bvh.prims[i] = refs[i].id;
  });
  const BvhNode& root = bvh.nodes[0];
  Aabb rb = child_box(root, 0);
  rb.grow(child_box(root, 1));
  bvh.bounds_min = rb.lo;
  bvh.bounds_max = rb.hi;
  bvh.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return bvh;
}

BvhTracer make_bvh_tracer(const Bvh& bvh, const SceneView& scene) {
  BvhTracer t;
  t.bvh = bvh.view();
  t.geometry.positions = scene.positions;
  t.geometry.indices = scene.indices;
  t.geometry.spheres = scene.spheres;
  return t;
}

double bvh_sah_cost(const Bvh& bvh, float traversal_cost, float intersection_cost) {
  if (bvh.nodes.empty()) return 0.0;
  double root_area = 0, sum = 0;
  for (size_t i = 0; i < bvh.nodes.size(); ++i) {
    const BvhNode& n = bvh.nodes[i];
    Aabb b0 = child_box(n, 0), b1 = child_box(n, 1), u = b0;
    u.grow(b1);
    if (i == 0) root_area = u.half_area();
    sum += double(traversal_cost) * u.half_area();
    for (int k = 0; k < 2; ++k)
      if (bvh_is_leaf(n.child[k]))
        sum += double(intersection_cost) * bvh_leaf_count(n.child[k]) * (k == 0 ? b0 : b1).half_area();
  }
  return root_area > 0 ? sum / root_area : 0.0;
}

}  // namespace luz
