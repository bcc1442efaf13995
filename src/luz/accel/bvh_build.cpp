// Binned SAH BVH construction (Wald 2007, "On fast construction of SAH-based
// bounding volume hierarchies"), parallel with TBB: large nodes are binned in
// parallel, and the two subtrees of every node above a size threshold are
// built as parallel tasks. Nodes are written straight in Aila & Laine's
// two-box format, then renumbered depth-first (a no-op on one thread), so the
// tree does not depend on the thread count or the task schedule.
//
// Speed (bench/RESULTS.md): per primitive, everything is done four lanes at
// a time with the compilers' generic vector types (SSE on x86-64, NEON on
// ARM, no -march needed). A primitive is one 32-byte PrimRef (box, id in the
// w lane). A node costs one binning pass (all three bin indices in one
// conversion; each bin grown by one min and one max; two sets of bins
// alternate so that runs of primitives in the same bin do not chain through
// memory) and one branch-free partition pass into a second buffer, which
// also gathers both children's centroid bounds: no third pass, no
// allocation, no mispredicted branch per primitive. The SAH sweep does the
// three axes at once. Nodes of at most kSweepMax primitives are swept
// exactly instead (their centroid ranks serve as bins), and pairs directly.
#include "luz/accel/bvh_build.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <stdexcept>

namespace luz {

namespace {

// ---------------------------------------------------------------- 4-wide floats

typedef float f4 __attribute__((vector_size(16)));
typedef int32_t i4 __attribute__((vector_size(16)));

inline f4 min4(f4 a, f4 b) { return a < b ? a : b; }
inline f4 max4(f4 a, f4 b) { return a > b ? a : b; }
inline f4 splat(float x) { return f4{x, x, x, x}; }
constexpr float kInf = kInfinity;

// xyz of a vector, w cleared: a PrimRef's w lane holds its id's bits (as a
// float, a denormal below 2^23, some normal number above: either way it must
// never reach arithmetic).
inline f4 xyz(f4 v) { return (f4)((i4)v & i4{-1, -1, -1, 0}); }

// A box as two 4-wide vectors (the w lanes are ignored).
struct Box {
  f4 lo{kInf, kInf, kInf, kInf}, hi{-kInf, -kInf, -kInf, -kInf};
  void grow(f4 l, f4 h) {
    lo = min4(lo, l);
    hi = max4(hi, h);
  }
  void grow(f4 p) { grow(p, p); }
  void grow(const Box& b) { grow(b.lo, b.hi); }
  bool empty() const { return !(lo[0] <= hi[0] && lo[1] <= hi[1] && lo[2] <= hi[2]); }
  // Half the surface area (the SAH only uses ratios); 0 when empty.
  float half_area() const {
    if (empty()) return 0.f;
    f4 e = xyz(hi) - xyz(lo);
    return e[0] * e[1] + e[1] * e[2] + e[2] * e[0];
  }
};

// Half area of a non-empty box, without the emptiness test (the sweeps).
inline float half_area(f4 lo, f4 hi) {
  f4 e = xyz(hi) - xyz(lo);
  return e[0] * e[1] + e[1] * e[2] + e[2] * e[0];
}

// A primitive during the build: its box, and its tagged id in the bits of
// lo's w lane. 32 bytes, partitioned in place so that every leaf ends up a
// contiguous range.
struct alignas(32) PrimRef {
  f4 lo, hi;
  uint32_t id() const { return std::bit_cast<uint32_t>(lo[3]); }
};


// Twice the box centre (w = 0).
inline f4 centroid2(const PrimRef& r) { return xyz(r.lo) + xyz(r.hi); }

inline void set_boxes(BvhNode& n, const Box& a, const Box& b) {
  n.c0_lx = a.lo[0], n.c0_hx = a.hi[0], n.c0_ly = a.lo[1], n.c0_hy = a.hi[1];
  n.c1_lx = b.lo[0], n.c1_hx = b.hi[0], n.c1_ly = b.lo[1], n.c1_hy = b.hi[1];
  n.c0_lz = a.lo[2], n.c0_hz = a.hi[2], n.c1_lz = b.lo[2], n.c1_hz = b.hi[2];
  n.pad[0] = n.pad[1] = 0;
}

constexpr int kMaxBins = 32;
constexpr size_t kParallelBinning = 1 << 15;  // bin nodes this large in parallel
constexpr size_t kParallelSubtree = 1 << 11;  // build subtrees this large as tasks
constexpr int kSweepMax = 32;                 // exact sweep at or below this size
static_assert(kSweepMax <= kMaxBins);

// Bins on the three axes: bin i of axis a holds the bounds of the
// primitives whose centroid fell into it (lo[a][i], hi[a][i], w lanes 0)
// and their number (count[i][a]).
struct Bins {
  f4 lo[3][kMaxBins], hi[3][kMaxBins];
  i4 count[kMaxBins];
  void clear(int nb) {
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < nb; ++i) {
        lo[a][i] = splat(kInf);
        hi[a][i] = splat(-kInf);
      }
    for (int i = 0; i < nb; ++i) count[i] = i4{0, 0, 0, 0};
  }
  void merge(const Bins& o, int nb) {
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < nb; ++i) {
        lo[a][i] = min4(lo[a][i], o.lo[a][i]);
        hi[a][i] = max4(hi[a][i], o.hi[a][i]);
      }
    for (int i = 0; i < nb; ++i) count[i] += o.count[i];
  }
  // Adds a box (w lanes 0) to bin k[a] of each axis a.
  void add(i4 k, f4 l, f4 h) {
    int k0 = k[0], k1 = k[1], k2 = k[2];
    lo[0][k0] = min4(lo[0][k0], l);
    hi[0][k0] = max4(hi[0][k0], h);
    count[k0][0] += 1;
    lo[1][k1] = min4(lo[1][k1], l);
    hi[1][k1] = max4(hi[1][k1], h);
    count[k1][1] += 1;
    lo[2][k2] = min4(lo[2][k2], l);
    hi[2][k2] = max4(hi[2][k2], h);
    count[k2][2] += 1;
  }
};

// Half areas of three boxes at once (lanes 0..2; lane 3 is junk), from the
// boxes' extents e0, e1, e2: a 3×3 transpose, then the same expression as
// Box::half_area.
inline f4 half_areas3(f4 e0, f4 e1, f4 e2) {
  f4 t0 = __builtin_shufflevector(e0, e1, 0, 4, 1, 5);  // e0x e1x e0y e1y
  f4 t1 = __builtin_shufflevector(e0, e1, 2, 6, 3, 7);  // e0z e1z . .
  f4 x = __builtin_shufflevector(t0, e2, 0, 1, 4, 4);
  f4 y = __builtin_shufflevector(t0, e2, 2, 3, 5, 5);
  f4 z = __builtin_shufflevector(t1, e2, 0, 1, 6, 6);
  return x * y + y * z + z * x;
}

// The SAH sweep over bins [0, nb) of all three axes at once (lane a = axis
// a): the cost, area × count summed over both sides, of splitting after
// each bin. Axes with axis_ok[a] == 0 are skipped. Returns the best
// (lowest cost; ties: lowest bin, then lowest axis) in axis/bin/cost, or
// false when no bin boundary separates the primitives.
bool sweep_bins(const Bins& bins, int nb, i4 axis_ok, int& axis, int& bin, float& cost) {
  f4 right_area[kMaxBins];
  i4 right_count[kMaxBins];
  {
    f4 lx = splat(kInf), ly = lx, lz = lx, hx = splat(-kInf), hy = hx, hz = hx;
    i4 cnt{0, 0, 0, 0};
    for (int i = nb - 1; i > 0; --i) {
      lx = min4(lx, bins.lo[0][i]), hx = max4(hx, bins.hi[0][i]);
      ly = min4(ly, bins.lo[1][i]), hy = max4(hy, bins.hi[1][i]);
      lz = min4(lz, bins.lo[2][i]), hz = max4(hz, bins.hi[2][i]);
      cnt += bins.count[i];
      right_area[i] = half_areas3(hx - lx, hy - ly, hz - lz);
      right_count[i] = cnt;
    }
  }
  f4 lx = splat(kInf), ly = lx, lz = lx, hx = splat(-kInf), hy = hx, hz = hx;
  i4 cnt{0, 0, 0, 0};
  f4 best = splat(kInf);
  i4 best_bin{-1, -1, -1, -1};
  const i4 zero{0, 0, 0, 0};
  for (int i = 0; i < nb - 1; ++i) {
    lx = min4(lx, bins.lo[0][i]), hx = max4(hx, bins.hi[0][i]);
    ly = min4(ly, bins.lo[1][i]), hy = max4(hy, bins.hi[1][i]);
    lz = min4(lz, bins.lo[2][i]), hz = max4(hz, bins.hi[2][i]);
    cnt += bins.count[i];
    i4 rc = right_count[i + 1];
    f4 c = half_areas3(hx - lx, hy - ly, hz - lz) * __builtin_convertvector(cnt, f4) +
           right_area[i + 1] * __builtin_convertvector(rc, f4);
    i4 better = (c < best) & (cnt != zero) & (rc != zero) & (axis_ok != zero);
    best = better ? c : best;
    best_bin = better ? i4{i, i, i, i} : best_bin;
  }
  int a = 0;
  if (best[1] < best[a]) a = 1;
  if (best[2] < best[a]) a = 2;
  if (best_bin[a] < 0) return false;
  axis = a, bin = best_bin[a], cost = best[a];
  return true;
}

// Which bin a centroid falls into, on all three axes at once: the one
// function used both to bin and to partition, so the two always agree.
struct Binner {
  f4 cmin, scale, top;  // scale = 0 on axes where the centroids have no extent
  Binner(const Box& cb, int bins) : cmin(xyz(cb.lo)), scale(splat(0.f)), top(splat(float(bins - 1))) {
    for (int a = 0; a < 3; ++a) {
      float ext = cb.hi[a] - cb.lo[a];
      scale[a] = ext > 0.f ? float(bins) * (1.f - 1e-6f) / ext : 0.f;
    }
  }
  i4 axis_ok() const { return scale > splat(0.f); }
  bool degenerate() const { return scale[0] == 0.f && scale[1] == 0.f && scale[2] == 0.f; }
  // max() first sends NaN to bin 0.
  i4 bin(f4 c2) const { return __builtin_convertvector(min4(max4((c2 - cmin) * scale, splat(0.f)), top), i4); }
};

// Bins refs[b, e) into `bins` (cleared, nb bins). Large ranges alternate
// between two sets of bins, merged at the end: consecutive primitives tend to
// fall into the same bins, and one set would chain every update to the
// previous one through memory.
void bin_range(const Binner& bn, const PrimRef* refs, size_t b, size_t e, Bins& bins, int nb) {
  size_t i = b;
  if (e - b >= 256) {
    Bins other;
    other.clear(nb);
    for (; i + 1 < e; i += 2) {
      f4 lo0 = xyz(refs[i].lo), hi0 = refs[i].hi, lo1 = xyz(refs[i + 1].lo), hi1 = refs[i + 1].hi;
      bins.add(bn.bin(lo0 + hi0), lo0, hi0);
      other.add(bn.bin(lo1 + hi1), lo1, hi1);
    }
    bins.merge(other, nb);
  }
  for (; i < e; ++i) {
    f4 lo = xyz(refs[i].lo), hi = refs[i].hi;
    bins.add(bn.bin(lo + hi), lo, hi);
  }
}

// The builder. Primitive references live in two buffers: a node's are in
// buf_[side][b, e), and splitting it moves them, partitioned, to the same
// range of the other buffer (out of place: branch-free, where an in-place
// partition mispredicts about every other primitive once the order is
// scrambled). A leaf writes its ids straight into the output array.
class Builder {
 public:
  // nodes: room for max(n - 1, 1) nodes (a binary tree over n leaves has
  // n - 1 inner nodes at most); prims: n output references.
  Builder(PrimRef* a, PrimRef* b, BvhNode* nodes, uint32_t* prims, size_t n, const BvhBuildOptions& opt)
      : buf_{a, b}, nodes_(nodes), prims_(prims), n_(n), opt_(opt) {
    nb_ = std::clamp(opt.bins, 2, kMaxBins);
    max_leaf_ = std::clamp<uint32_t>(opt.max_leaf_size, 1, kBvhMaxLeafSize);
  }

  // Builds the whole tree over buf_[0][0, n) (bounds box, centroid bounds
  // cbox) into nodes (root = index 0; a child's index is larger than its
  // parent's; depth-first order when built on one thread); returns the
  // number of nodes.
  uint32_t run(const Box& box, const Box& cbox) {
    uint32_t root = alloc();
    if (n_ == 1) {
      // One primitive: a root whose second child is an empty leaf.
      set_boxes(nodes_[root], box, box);
      nodes_[root].child[0] = make_leaf(0, 1, 0);
      nodes_[root].child[1] = bvh_make_leaf(0, 0);
    } else {
      Split s;
      split(0, n_, 0, box, cbox, 1, false, s);
      fill(root, 0, n_, 1, s, 1);
    }
    return next_.load();
  }

 private:
  PrimRef* buf_[2];
  BvhNode* nodes_;
  uint32_t* prims_;
  size_t n_;
  const BvhBuildOptions& opt_;
  std::atomic<uint32_t> next_{0};
  int nb_;
  uint32_t max_leaf_;

  uint32_t alloc() { return next_.fetch_add(1, std::memory_order_relaxed); }

  uint32_t make_leaf(size_t b, size_t e, int side) {
    const PrimRef* p = buf_[side];
    for (size_t i = b; i < e; ++i) prims_[i] = p[i].id();
    return bvh_make_leaf(uint32_t(b), uint32_t(e - b));
  }

  // A split of [b, e) at `mid` (both sides now in the other buffer), with
  // both sides' bounds and centroid bounds.
  struct Split {
    size_t mid;
    Box lbox, lcbox, rbox, rcbox;
  };

  static void bounds(const PrimRef* p, size_t b, size_t e, Box& box, Box& cbox) {
    for (size_t i = b; i < e; ++i) {
      box.grow(xyz(p[i].lo), p[i].hi);
      cbox.grow(centroid2(p[i]));
    }
  }

  // Object median along the widest centroid axis (the fallback, the depth
  // guard and the baseline builder).
  void median_split(size_t b, size_t e, int side, const Box& cbox, Split& s) {
    PrimRef* d = buf_[side ^ 1];
    std::copy(buf_[side] + b, buf_[side] + e, d + b);
    f4 ext = cbox.hi - cbox.lo;
    int axis = ext[0] >= ext[1] ? (ext[0] >= ext[2] ? 0 : 2) : (ext[1] >= ext[2] ? 1 : 2);
    size_t mid = b + (e - b) / 2;
    if (ext[axis] > 0.f)
      std::nth_element(d + b, d + mid, d + e, [axis](const PrimRef& x, const PrimRef& y) {
        return centroid2(x)[axis] < centroid2(y)[axis];
      });
    s.mid = mid;
    bounds(d, b, mid, s.lbox, s.lcbox);
    bounds(d, mid, e, s.rbox, s.rcbox);
  }

  // No plane separates the centroids: a leaf when allowed, else the median.
  bool unsplittable(size_t b, size_t e, int side, const Box& cbox, bool may_leaf, Split& s) {
    if (may_leaf) return false;
    median_split(b, e, side, cbox, s);
    return true;
  }

  // Whether a leaf of n primitives costs no more than the best split, whose
  // Σ area × count over both sides is `best` (node bounds: box).
  bool leaf_is_cheaper(size_t n, float best, const Box& box, bool may_leaf) const {
    if (!may_leaf) return false;
    float split_cost = opt_.traversal_cost + opt_.intersection_cost * best / std::max(box.half_area(), 1e-30f);
    return opt_.intersection_cost * float(n) <= split_cost;
  }

  // The reference builder (options.full_sweep): the exact SAH sweep of
  // sweep_split for any size, by sorting (O(n log n) per node).
  bool full_sweep_split(size_t b, size_t e, int side, const Box& box, const Box& cbox, bool may_leaf, Split& s) {
    const size_t n = e - b;
    const PrimRef* p = buf_[side] + b;
    std::vector<uint32_t> order(n), best_order;
    std::vector<float> right_area(n);
    float best = kInf;
    size_t best_i = 0;
    for (int a = 0; a < 3; ++a) {
      if (!(cbox.hi[a] > cbox.lo[a])) continue;
      for (size_t i = 0; i < n; ++i) order[i] = uint32_t(i);
      std::sort(order.begin(), order.end(), [&](uint32_t x, uint32_t y) {
        float cx = centroid2(p[x])[a], cy = centroid2(p[y])[a];
        return cx < cy || (cx == cy && x < y);
      });
      Box acc;
      for (size_t i = n - 1; i > 0; --i) {
        acc.grow(xyz(p[order[i]].lo), p[order[i]].hi);
        right_area[i] = acc.half_area();
      }
      acc = Box{};
      bool improved = false;
      for (size_t i = 0; i + 1 < n; ++i) {
        acc.grow(xyz(p[order[i]].lo), p[order[i]].hi);
        if (!(centroid2(p[order[i]])[a] < centroid2(p[order[i + 1]])[a])) continue;
        float c = acc.half_area() * float(i + 1) + right_area[i + 1] * float(n - i - 1);
        if (c < best) best = c, best_i = i + 1, improved = true;
      }
      if (improved) best_order = order;
    }
    if (best_i == 0) {
      return unsplittable(b, e, side, cbox, may_leaf, s);
    }
    if (leaf_is_cheaper(size_t(n), best, box, may_leaf)) return false;
    PrimRef* d = buf_[side ^ 1] + b;
    for (size_t i = 0; i < n; ++i) d[i] = p[best_order[i]];
    s.mid = b + best_i;
    bounds(buf_[side ^ 1], b, s.mid, s.lbox, s.lcbox);
    bounds(buf_[side ^ 1], s.mid, e, s.rbox, s.rcbox);
    return true;
  }

  // Two primitives: split them, or not (same rules as sweep_split).
  bool pair_split(size_t b, int side, const Box& box, bool may_leaf, Split& s) {
    const PrimRef* p = buf_[side] + b;
    f4 c0 = centroid2(p[0]), c1 = centroid2(p[1]);
    i4 lt = c1 < c0, ne = c0 != c1;
    // Coincident centroids: a leaf if allowed (else split all the same, as
    // the median would).
    if (!(ne[0] | ne[1] | ne[2]) && may_leaf) return false;
    Box b0, b1;
    b0.grow(xyz(p[0].lo), p[0].hi);
    b1.grow(xyz(p[1].lo), p[1].hi);
    if (leaf_is_cheaper(2, b0.half_area() + b1.half_area(), box, may_leaf)) return false;
    // The first axis on which the centroids differ orders them.
    int a = ne[0] ? 0 : ne[1] ? 1 : 2;
    int first = lt[a] ? 1 : 0;
    PrimRef* d = buf_[side ^ 1] + b;
    d[0] = p[first];
    d[1] = p[first ^ 1];
    s.lbox = first ? b1 : b0;
    s.rbox = first ? b0 : b1;
    s.lcbox.grow(first ? c1 : c0);
    s.rcbox.grow(first ? c0 : c1);
    s.mid = b + 1;
    return true;
  }

  // Exact SAH sweep for a small node: on each axis, the primitives' ranks
  // by centroid (how many centroids are strictly smaller: equal centroids
  // share a rank) serve as bin indices, so the bin sweep evaluates every
  // split between distinct centroids. Returns false (a leaf) when no split
  // beats a leaf and may_leaf; else fills s.
  bool sweep_split(size_t b, size_t e, int side, const Box& box, const Box& cbox, bool may_leaf, Split& s) {
    const int n = int(e - b);
    const PrimRef* p = buf_[side] + b;
    f4 cen[kSweepMax];
    for (int i = 0; i < n; ++i) cen[i] = centroid2(p[i]);
    i4 rank[kSweepMax];
    for (int i = 0; i < n; ++i) {
      i4 r{0, 0, 0, 0};
      for (int j = 0; j < n; ++j) r -= cen[j] < cen[i];
      rank[i] = r;
    }
    Bins bins;
    bins.clear(n);
    for (int i = 0; i < n; ++i) bins.add(rank[i], xyz(p[i].lo), p[i].hi);
    int axis, last;
    float best;
    if (!sweep_bins(bins, n, cbox.hi > cbox.lo, axis, last, best)) {
      // All centroids coincide.
      return unsplittable(b, e, side, cbox, may_leaf, s);
    }
    if (leaf_is_cheaper(size_t(n), best, box, may_leaf)) return false;
    PrimRef* d = buf_[side ^ 1] + b;
    int l = 0, r = n;
    for (int i = 0; i < n; ++i) {
      if (rank[i][axis] <= last) {
        d[l++] = p[i];
        s.lbox.grow(xyz(p[i].lo), p[i].hi);
        s.lcbox.grow(cen[i]);
      } else {
        d[--r] = p[i];
        s.rbox.grow(xyz(p[i].lo), p[i].hi);
        s.rcbox.grow(cen[i]);
      }
    }
    s.mid = b + size_t(l);
    return true;
  }

  // Branch-free partition of src[b, e) into dst[b, e): the left side
  // (bin ≤ last on `axis`) from b up, the right side from e down, each
  // primitive written to both ends and the end it belongs to advanced.
  // Returns the boundary; gathers both sides' centroid bounds.
  static size_t partition(const PrimRef* src, PrimRef* dst, size_t b, size_t e, const Binner& bn, int axis,
                          int last, Box& lcbox, Box& rcbox) {
    size_t l = b, r = e;
    const f4 inf = splat(kInf), ninf = splat(-kInf);
    f4 llo = inf, lhi = ninf, rlo = inf, rhi = ninf;
    for (size_t i = b; i < e; ++i) {
      PrimRef x = src[i];
      f4 c = centroid2(x);
      int left = bn.bin(c)[axis] <= last;
      dst[l] = x;
      dst[r - 1] = x;
      l += size_t(left);
      r -= size_t(1 - left);
      i4 m = i4{0, 0, 0, 0} - left;  // all ones: left
      llo = min4(llo, m ? c : inf);
      lhi = max4(lhi, m ? c : ninf);
      rlo = min4(rlo, m ? inf : c);
      rhi = max4(rhi, m ? ninf : c);
    }
    lcbox.grow(llo, lhi);
    rcbox.grow(rlo, rhi);
    return l;
  }

  // Best SAH split of [b, e) in buf_[side] (bounds box, centroid bounds
  // cbox). Returns false when a leaf is no more expensive (only if
  // may_leaf); else moves the primitives to the other buffer and fills s.
  bool split(size_t b, size_t e, int side, const Box& box, const Box& cbox, int depth, bool may_leaf, Split& s) {
    size_t n = e - b;
    if (opt_.median_split || depth + int(std::bit_width(n - 1)) >= kBvhStackSize - 2)
      return unsplittable(b, e, side, cbox, may_leaf, s);
    if (opt_.full_sweep && n > 2) return full_sweep_split(b, e, side, box, cbox, may_leaf, s);
    if (n == 2) return pair_split(b, side, box, may_leaf, s);
    if (n <= size_t(kSweepMax)) return sweep_split(b, e, side, box, cbox, may_leaf, s);
    // No more bins than primitives. (Fewer, n/4, measured a few % faster
    // but changed the SAH cost by -0.2% on Sponza, +0.6% on the staircase.)
    int nb = int(std::min<size_t>(size_t(nb_), n));
    Binner bn(cbox, nb);
    if (bn.degenerate()) {
      // All centroids coincide: no plane separates them.
      return unsplittable(b, e, side, cbox, may_leaf, s);
    }
    const PrimRef* src = buf_[side];
    Bins bins;
    bins.clear(nb);
    if (n >= kParallelBinning) {
      bins = tbb::parallel_reduce(
          tbb::blocked_range<size_t>(b, e, 8192), bins,
          [&](const tbb::blocked_range<size_t>& r, Bins acc) {
            bin_range(bn, src, r.begin(), r.end(), acc, nb);
            return acc;
          },
          [nb](Bins x, const Bins& y) {
            x.merge(y, nb);
            return x;
          });
    } else {
      bin_range(bn, src, b, e, bins, nb);
    }
    int axis, last;
    float best;
    if (!sweep_bins(bins, nb, bn.axis_ok(), axis, last, best)) {
      // Every axis put all centroids into one bin (extreme clustering).
      return unsplittable(b, e, side, cbox, may_leaf, s);
    }
    if (leaf_is_cheaper(size_t(n), best, box, may_leaf)) return false;

    for (int i = 0; i <= last; ++i) s.lbox.grow(bins.lo[axis][i], bins.hi[axis][i]);
    for (int i = last + 1; i < nb; ++i) s.rbox.grow(bins.lo[axis][i], bins.hi[axis][i]);
    s.mid = partition(src, buf_[side ^ 1], b, e, bn, axis, last, s.lcbox, s.rcbox);
    return true;
  }

  // Child reference for [b, e) in buf_[side]: a leaf, or a new inner node.
  uint32_t make_child(size_t b, size_t e, int side, const Box& box, const Box& cbox, int depth) {
    size_t n = e - b;
    if (n <= 1) return make_leaf(b, e, side);
    Split s;
    if (!split(b, e, side, box, cbox, depth, n <= max_leaf_, s)) return make_leaf(b, e, side);
    uint32_t node = alloc();
    fill(node, b, e, side ^ 1, s, depth);
    return node;
  }

  // Fills inner node `node` split by s; its children are in buf_[side].
  void fill(uint32_t node, size_t b, size_t e, int side, const Split& s, int depth) {
    BvhNode& t = nodes_[node];
    set_boxes(t, s.lbox, s.rbox);
    if (e - b >= kParallelSubtree) {
      tbb::parallel_invoke([&] { t.child[0] = make_child(b, s.mid, side, s.lbox, s.lcbox, depth + 1); },
                           [&] { t.child[1] = make_child(s.mid, e, side, s.rbox, s.rcbox, depth + 1); });
    } else {
      t.child[0] = make_child(b, s.mid, side, s.lbox, s.lcbox, depth + 1);
      t.child[1] = make_child(s.mid, e, side, s.rbox, s.rcbox, depth + 1);
    }
  }
};

// Lays the tree out depth-first (deterministic whatever the task schedule
// was): out = tmp[0, count) renumbered in pre-order. Also counts the leaves
// and the depth.
void flatten(const BvhNode* tmp, uint32_t count, Bvh& out) {
  std::vector<uint32_t> order, renum(count);
  order.reserve(count);
  struct Item {
    uint32_t node, depth;
  };
  std::vector<Item> stack{{0, 1}};
  bool identity = true;
  while (!stack.empty()) {
    Item it = stack.back();
    stack.pop_back();
    renum[it.node] = uint32_t(order.size());
    identity &= it.node == order.size();
    order.push_back(it.node);
    out.max_depth = std::max(out.max_depth, it.depth);
    const BvhNode& n = tmp[it.node];
    for (int k = 1; k >= 0; --k) {
      if (!bvh_is_leaf(n.child[k]))
        stack.push_back({n.child[k], it.depth + 1});
      else if (bvh_leaf_count(n.child[k]) > 0)
        ++out.num_leaves;
    }
  }
  if (identity) {
    out.nodes.assign(tmp, tmp + count);
    return;
  }
  out.nodes.resize(count);
  for (uint32_t i = 0; i < count; ++i) {
    BvhNode n = tmp[order[i]];
    for (int k = 0; k < 2; ++k)
      if (!bvh_is_leaf(n.child[k])) n.child[k] = renum[n.child[k]];
    out.nodes[i] = n;
  }
}

Box child_box(const BvhNode& n, int k) {
  Box b;
  if (k == 0) {
    b.lo = f4{n.c0_lx, n.c0_ly, n.c0_lz, 0.f};
    b.hi = f4{n.c0_hx, n.c0_hy, n.c0_hz, 0.f};
  } else {
    b.lo = f4{n.c1_lx, n.c1_ly, n.c1_lz, 0.f};
    b.hi = f4{n.c1_hx, n.c1_hy, n.c1_hz, 0.f};
  }
  return b;
}

struct RootBounds {
  Box box, cbox;
};

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
    // PrimRefs and the root's bounds in one pass. (A plain array: a
    // std::vector would zero 32 bytes per primitive first.)
    std::unique_ptr<PrimRef[]> refs(new PrimRef[n]);
    PrimRef* rp = refs.get();
    auto make_refs = [&](size_t b, size_t e, RootBounds acc) {
      for (size_t i = b; i < e; ++i) {
        Vec3 lo, hi;
        uint32_t id;
        if (i < nt) {
          const uint32_t* ix = scene.indices + 3 * i;
          Vec3 a = scene.positions[ix[0]], b2 = scene.positions[ix[1]], c = scene.positions[ix[2]];
          lo = vmin(a, vmin(b2, c));
          hi = vmax(a, vmax(b2, c));
          id = uint32_t(i);
        } else {
          const Sphere& s = scene.spheres[i - nt];
          // A few ulps of slack for intersect_sphere's rounding near tangents.
          float m = max(fabsf(s.center.x), max(fabsf(s.center.y), fabsf(s.center.z))) + fabsf(s.radius);
          float r = fabsf(s.radius) + m * 0x1p-20f;
          // Clamped to the finite range: a huge sphere's box would otherwise
          // reach ±inf on both sides, its centroid NaN, and NaN makes the
          // min/max reductions depend on how the work is split (the tree on
          // the thread count). Nothing beyond FLT_MAX can be hit anyway.
          const float big = 3.40282347e38f;
          lo = vmax(s.center - Vec3{r, r, r}, Vec3{-big, -big, -big});
          hi = vmin(s.center + Vec3{r, r, r}, Vec3{big, big, big});
          id = uint32_t(i - nt) | kBvhSphereBit;
        }
        PrimRef& p = rp[i];
        p.lo = f4{lo.x, lo.y, lo.z, std::bit_cast<float>(id)};
        p.hi = f4{hi.x, hi.y, hi.z, 0.f};
        acc.box.grow(xyz(p.lo), p.hi);
        acc.cbox.grow(centroid2(p));
      }
      return acc;
    };
    RootBounds rb = n < 8192 ? make_refs(0, n, RootBounds{})
                             : tbb::parallel_reduce(
                                   tbb::blocked_range<size_t>(0, n, 4096), RootBounds{},
                                   [&](const tbb::blocked_range<size_t>& r, RootBounds acc) {
                                     return make_refs(r.begin(), r.end(), acc);
                                   },
                                   [](RootBounds x, const RootBounds& y) {
                                     x.box.grow(y.box);
                                     x.cbox.grow(y.cbox);
                                     return x;
                                   });
    std::unique_ptr<PrimRef[]> scratch(new PrimRef[n]);
    std::unique_ptr<BvhNode[]> nodes(new BvhNode[std::max<size_t>(n - 1, 1)]);
    bvh.prims.resize(n);
    Builder builder(rp, scratch.get(), nodes.get(), bvh.prims.data(), n, options);
    uint32_t count = builder.run(rb.box, rb.cbox);
    flatten(nodes.get(), count, bvh);
  });
  const BvhNode& root = bvh.nodes[0];
  Box rb = child_box(root, 0);
  rb.grow(child_box(root, 1));
  bvh.bounds_min = {rb.lo[0], rb.lo[1], rb.lo[2]};
  bvh.bounds_max = {rb.hi[0], rb.hi[1], rb.hi[2]};
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
    Box b0 = child_box(n, 0), b1 = child_box(n, 1), u = b0;
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
