// Binned SAH BVH construction (Wald 2007, "On fast construction of SAH-based
// bounding volume hierarchies"), parallel with TBB: large nodes are binned
// and partitioned in parallel, and the two subtrees of every node above a
// size threshold are built as parallel tasks. Nodes are written straight in
// Aila & Laine's two-box format, in depth-first order on one thread; on more
// they are renumbered depth-first afterwards, so the tree does not depend
// on the thread count or the task schedule.
//
// Speed (bench/RESULTS.md): per primitive, everything is done four lanes at
// a time with the compilers' generic vector types (SSE on x86-64, NEON on
// ARM, no -march needed). A primitive is one 32-byte PrimRef (box, id in the
// w lane). A node costs one binning pass (all three bin indices in one
// conversion; each bin grown by one min, one max, its count riding in the
// min's w lane; two or four sets of bins alternate so that runs of
// primitives in the same bin do not chain through memory) and one
// branch-free partition pass into a second buffer that writes each
// primitive once. The children's centroid bounds come from the bins, not
// from a pass. The SAH sweep does the three axes at once. Subtrees of at
// most kSweepMax primitives are built apart with an exact sweep at every
// node, over lists sorted once at the subtree's root. Above them, the
// default build bins clusters of up to 16 primitives, neighbours in Morton
// order, rather than primitives (ClusterBuilder; the primitive builder,
// Builder, remains for BvhBuildOptions::clusters = false, the reference
// options, scenes of at most kSweepMax primitives, and the clusters'
// degenerate cases). Large arrays are on huge pages where the kernel offers
// them (page faults otherwise cost as much as the build above a million
// primitives), and the nodes are made in the output vector itself
// (BuildAllocator: no zeroing, no final copy; on more than one thread
// stored densely as threads make them, put in order after: compact).
//
// Where the time goes (the staircase, 263k triangles, one thread, on reused
// memory; callgrind, 1,064 instructions per primitive): the small subtrees
// 46% (their sweeps and list partitions 37%, the presorts 9%), the
// clusters' binning, sweeps and partitions 20%, the Morton keys, radix
// sort, gather and cuts 19%, reordering the runs of equal Morton codes 9%
// (57% of the staircase's triangles), the PrimRefs 4%. No line stands out:
// the sweeps' cost is spread over their min/max, area and partition steps.
// At about 2.5 instructions per cycle, fewer instructions did not always
// measure faster (bench/RESULTS.md). The primitive builder took 1.35× as
// long on Sponza (1.6× on the staircase) before kClusterSweep: binning 32%,
// the small subtrees 33%, partition and bin sweeps 19%, the depth-first
// renumbering 5%. Fresh memory can be slow on the VMs measured: on the
// staircase, a build on freshly mapped memory (about 95 bytes per
// primitive: PrimRefs twice, the nodes, the references) took 1.4-1.9× as
// long as the same build on memory reused (BvhScratch) at 0d48be2, the
// kernel zeroing and mapping pages (1.04× in the quieter run at 29cebca).
#include "luz/accel/bvh_build.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <stdexcept>
#include <utility>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

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
static_assert(alignof(PrimRef) <= 64);  // BvhScratch's alignment


// Twice the box centre (w = 0).
inline f4 centroid2(const PrimRef& r) { return xyz(r.lo) + xyz(r.hi); }

inline void set_boxes(BvhNode& n, const Box& a, const Box& b) {
  n.c0_lx = a.lo[0], n.c0_hx = a.hi[0], n.c0_ly = a.lo[1], n.c0_hy = a.hi[1];
  n.c1_lx = b.lo[0], n.c1_hx = b.hi[0], n.c1_ly = b.lo[1], n.c1_hy = b.hi[1];
  n.c0_lz = a.lo[2], n.c0_hz = a.hi[2], n.c1_lz = b.lo[2], n.c1_hz = b.hi[2];
}

constexpr int kMaxBins = 32;
constexpr uint32_t kHole = ~uint32_t(0);  // a parallel build's unused node slot (its pad[0]; see Builder::Out)
constexpr size_t kParallelBinning = 1 << 15;  // bin nodes this large in parallel
// ... and nodes of this many clusters (each stands for 4 to 9 primitives on
// the scenes measured: the top levels of the staircase's and Sponza's
// cluster trees would otherwise be binned and partitioned on one thread).
constexpr size_t kParallelClusters = 1 << 14;
constexpr size_t kParallelSubtree = 1 << 11;  // build subtrees this large as tasks
constexpr int kSweepMax = 32;                 // small subtrees: exact sweeps at or below this size
static_assert(kSweepMax <= 64);               // one bit per primitive in a uint64_t

// Bins on the three axes: bin i of axis a holds the bounds of the
// primitives whose centroid fell into it (lo[a][i], hi[a][i]) and their
// number, kept in the w lane of lo[a][i] so that adding a primitive to a bin
// writes two vectors, not three. The count is stored as the bits of a normal
// float, kCountBase + count: an integer add increments it, and it never
// meets a denormal (flushed to zero where DAZ is set).
constexpr int32_t kCountBase = 0x00800000;  // FLT_MIN's bits
inline constexpr i4 kOneW{0, 0, 0, 1};

// A box's lo for Bins::add: xyz of the primitive's lo, w a NaN (from the id
// bits in lo's w lane), which min4(l, bin) never picks, so the bin's count
// passes through the min untouched.
inline f4 bin_lo(f4 lo) { return (f4)((i4)lo | i4{0, 0, 0, 0x7fc00000}); }

struct Bins {
  f4 lo[3][kMaxBins], hi[3][kMaxBins];
  void clear(int nb) {
    const f4 empty_lo = (f4)i4{std::bit_cast<int32_t>(kInf), std::bit_cast<int32_t>(kInf),
                               std::bit_cast<int32_t>(kInf), kCountBase};
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < nb; ++i) {
        lo[a][i] = empty_lo;
        hi[a][i] = splat(-kInf);
      }
  }
  void merge(const Bins& o, int nb) {
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < nb; ++i) {
        i4 count = (i4)o.lo[a][i] - i4{0, 0, 0, kCountBase};
        lo[a][i] = (f4)((i4)min4(bin_lo(o.lo[a][i]), lo[a][i]) + (count & i4{0, 0, 0, -1}));
        hi[a][i] = max4(hi[a][i], o.hi[a][i]);
      }
  }
  // Counts of bin i on the three axes (lanes 0..2; lane 3 is 0).
  i4 count(int i) const {
    i4 w = __builtin_shufflevector((i4)lo[0][i], (i4)lo[1][i], 3, 7, 3, 7);
    i4 c = __builtin_shufflevector(w, (i4)lo[2][i], 0, 1, 7, 7);
    return (c - i4{kCountBase, kCountBase, kCountBase, kCountBase}) & i4{-1, -1, -1, 0};
  }
  // Adds a box (l from bin_lo, h with w lane 0) to bin k[a] of each axis a.
  // The three bins' byte offsets are computed in one vector (lo[a][k] lies
  // a·kMaxBins + k vectors into lo) and used unsigned, which saves the sign
  // extensions and scalings of three array indices.
  void add(i4 k, f4 l, f4 h, i4 count = kOneW) {
    constexpr int32_t kAxis = kMaxBins * sizeof(f4);
    constexpr ptrdiff_t kHi = 3 * kAxis;  // from lo[a][k] to hi[a][k]
    static_assert(offsetof(Bins, hi) == kHi);
    const i4 off = (k << 4) + i4{0, kAxis, 2 * kAxis, 0};
    char* base = reinterpret_cast<char*>(lo);
    f4* l0 = reinterpret_cast<f4*>(base + uint32_t(off[0]));
    f4* l1 = reinterpret_cast<f4*>(base + uint32_t(off[1]));
    f4* l2 = reinterpret_cast<f4*>(base + uint32_t(off[2]));
    *l0 = (f4)((i4)min4(l, *l0) + count);
    l0[kHi / 16] = max4(l0[kHi / 16], h);
    *l1 = (f4)((i4)min4(l, *l1) + count);
    l1[kHi / 16] = max4(l1[kHi / 16], h);
    *l2 = (f4)((i4)min4(l, *l2) + count);
    l2[kHi / 16] = max4(l2[kHi / 16], h);
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
  // From the right first: right_cost[i], the area of bins [i, nb) times
  // their count, or +inf where they are empty or the axis is skipped (as
  // small_sweep does: the loop that keeps the best then carries less).
  f4 right_cost[kMaxBins];
  const i4 zero{0, 0, 0, 0};
  {
    f4 lx = splat(kInf), ly = lx, lz = lx, hx = splat(-kInf), hy = hx, hz = hx;
    i4 cnt{0, 0, 0, 0};
    for (int i = nb - 1; i > 0; --i) {
      lx = min4(lx, bins.lo[0][i]), hx = max4(hx, bins.hi[0][i]);
      ly = min4(ly, bins.lo[1][i]), hy = max4(hy, bins.hi[1][i]);
      lz = min4(lz, bins.lo[2][i]), hz = max4(hz, bins.hi[2][i]);
      cnt += bins.count(i);
      const f4 c = half_areas3(hx - lx, hy - ly, hz - lz) * __builtin_convertvector(cnt, f4);
      right_cost[i] = ((cnt != zero) & (axis_ok != zero)) ? c : splat(kInf);
    }
  }
  f4 lx = splat(kInf), ly = lx, lz = lx, hx = splat(-kInf), hy = hx, hz = hx;
  i4 cnt{0, 0, 0, 0};
  f4 best = splat(kInf);
  i4 best_bin{-1, -1, -1, -1};
  for (int i = 0; i < nb - 1; ++i) {
    lx = min4(lx, bins.lo[0][i]), hx = max4(hx, bins.hi[0][i]);
    ly = min4(ly, bins.lo[1][i]), hy = max4(hy, bins.hi[1][i]);
    lz = min4(lz, bins.lo[2][i]), hz = max4(hz, bins.hi[2][i]);
    cnt += bins.count(i);
    const f4 c = half_areas3(hx - lx, hy - ly, hz - lz) * __builtin_convertvector(cnt, f4) + right_cost[i + 1];
    const i4 better = (c < best) & (cnt != zero);
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
  // The partition's side test for a split after bin `last` (< nb − 1) on
  // axis a: whether centroid c2 falls into a bin ≤ last. bin() takes
  // ⌊clamp(v, 0, nb − 1)⌋ of v = (c2 − cmin)·scale; since last + 1 ≤ nb − 1,
  // that is ≤ last exactly when v < last + 1 or v is NaN (max() sends NaN to
  // bin 0). So the test computes the same v by the same IEEE operations and
  // compares it with last + 1: the binning's answer, without the clamps and
  // the conversion.
  struct SideTest {
    float cmin, scale, limit;
    bool left(float c2) const { return !((c2 - cmin) * scale >= limit); }
  };
  SideTest side_test(int a, int last) const { return {cmin[a], scale[a], float(last + 1)}; }
};

// Bins refs[b, e) into `bins` (cleared, nb bins). Ranges of 64 or more
// alternate between two sets of bins (four from 1024), merged at the end:
// consecutive primitives tend to fall into the same bins, and one set would
// chain every update to the previous one through memory. kClusters: the
// references are clusters (ClusterBuilder), each counting for the
// primitives it holds (hi's w lane: kCountBase + count).
template <bool kClusters = false>
void bin_range(const Binner& bn, const PrimRef* refs, size_t b, size_t e, Bins& bins, int nb) {
  size_t i = b;
  auto add = [&](Bins& to, size_t k) {
    f4 lo = xyz(refs[k].lo), hi = refs[k].hi;
    if constexpr (kClusters)
      to.add(bn.bin(lo + hi), bin_lo(lo), hi, ((i4)hi - i4{0, 0, 0, kCountBase}) & i4{0, 0, 0, -1});
    else
      to.add(bn.bin(lo + hi), bin_lo(lo), hi);
  };
  if (e - b >= 1024) {
    Bins o1, o2, o3;
    o1.clear(nb), o2.clear(nb), o3.clear(nb);
    for (; i + 3 < e; i += 4) add(bins, i), add(o1, i + 1), add(o2, i + 2), add(o3, i + 3);
    o1.merge(o3, nb);
    bins.merge(o2, nb);
    bins.merge(o1, nb);
  } else if (e - b >= 64) {
    Bins other;
    other.clear(nb);
    for (; i + 1 < e; i += 2) add(bins, i), add(other, i + 1);
    bins.merge(other, nb);
  }
  for (; i < e; ++i) add(bins, i);
}

// refs[b, e) binned (nb bins) into `bins`: in parallel blocks from
// parallel_from references on. (An out parameter: returned, the 3 KiB
// of bins were copied at every node, 2.5% of the build.)
template <bool kClusters = false>
void bin_all(const Binner& bn, const PrimRef* refs, size_t b, size_t e, int nb, Bins& bins,
             size_t parallel_from = kParallelBinning) {
  bins.clear(nb);
  if (e - b < parallel_from) {
    bin_range<kClusters>(bn, refs, b, e, bins, nb);
    return;
  }
  bins = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(b, e, 8192), bins,
      [&](const tbb::blocked_range<size_t>& r, Bins acc) {
        bin_range<kClusters>(bn, refs, r.begin(), r.end(), acc, nb);
        return acc;
      },
      [nb](Bins x, const Bins& y) {
        x.merge(y, nb);
        return x;
      });
}

// When every axis put all centroids into one bin: the centroid bounds a node
// gets from its parent's bins may be far looser than its centroids' (a
// primitive much larger than the rest). True, with the exact bounds of
// refs[b, e), when they differ from cbox (then bin again over them).
bool tighter_centroid_bounds(const PrimRef* refs, size_t b, size_t e, const Box& cbox, Box& exact) {
  for (size_t i = b; i < e; ++i) exact.grow(centroid2(refs[i]));
  i4 same = (xyz(exact.lo) == xyz(cbox.lo)) & (xyz(exact.hi) == xyz(cbox.hi));
  return !(same[0] & same[1] & same[2]);
}

// Parallel partitions work in blocks: the number of primitives of [b, e)
// going left before each block (blocks + 1 prefix sums), counted in parallel.
constexpr size_t kPartitionBlock = 8192;
std::vector<size_t> left_before_blocks(const PrimRef* src, size_t b, size_t e, Binner::SideTest test, int axis) {
  const size_t blocks = (e - b + kPartitionBlock - 1) / kPartitionBlock;
  std::vector<size_t> left_before(blocks + 1, 0);
  tbb::parallel_for(size_t(0), blocks, [&](size_t k) {
    size_t i0 = b + k * kPartitionBlock, i1 = std::min(e, i0 + kPartitionBlock), nl = 0;
    for (size_t i = i0; i < i1; ++i) nl += size_t(test.left(src[i].lo[axis] + src[i].hi[axis]));
    left_before[k + 1] = nl;
  });
  for (size_t k = 0; k < blocks; ++k) left_before[k + 1] += left_before[k];
  return left_before;
}

// ---------------------------------------------------------------- sorting networks
//
// The small subtrees' presort: keys of up to kSweepMax primitives sorted on
// the three axes at once by a fixed network of compare-exchanges (Batcher's
// odd-even merge sort), one 4 × 64-bit vector per key, lane a for axis a.
// A key holds the centroid on a as an ordered integer (signed order = the
// floats' order) in its high half and the primitive's index in its low
// half, so that ties go by index. A network over N inputs that only meets
// padding (the largest key) at positions ≥ n sorts n once the comparators
// touching those positions are left out: the padding never moves.

typedef int64_t l4 __attribute__((vector_size(32)));

struct Comparator {
  uint8_t a, b;
};

// Batcher's network for the next power of two ≥ n, cut down to n inputs
// (count only: with out == nullptr).
constexpr int batcher(int n, Comparator* out) {
  int m = 1, count = 0;
  while (m < n) m *= 2;
  for (int p = 1; p < m; p *= 2)
    for (int k = p; k >= 1; k /= 2)
      for (int j = k % p; j + k < m; j += 2 * k)
        for (int i = 0; i < std::min(k, m - j - k); ++i)
          if ((i + j) / (2 * p) == (i + j + k) / (2 * p) && i + j + k < n) {
            if (out) out[count] = {uint8_t(i + j), uint8_t(i + j + k)};
            ++count;
          }
  return count;
}

template <int N>
constexpr std::array<Comparator, batcher(N, nullptr)> kNetwork = [] {
  std::array<Comparator, batcher(N, nullptr)> c{};
  batcher(N, c.data());
  return c;
}();

// Sorts k[0, N) lane by lane (unrolled: the keys can stay in registers).
template <int N>
inline void sort_network(l4* k) {
  [&]<size_t... I>(std::index_sequence<I...>) {
    ((void)[&] {
      constexpr Comparator c = kNetwork<N>[I];
      const l4 x = k[c.a], y = k[c.b], swap = x > y;
      k[c.a] = swap ? y : x;
      k[c.b] = swap ? x : y;
    }(), ...);
  }(std::make_index_sequence<kNetwork<N>.size()>());
}

// The ordered-integer form of the floats x (w lane junk): flipping the
// magnitude bits of negative numbers makes signed integer order the float
// order (+ 0 first: -0 becomes +0, equal to it as a float).
inline i4 ordered(f4 x) {
  const i4 b = (i4)(x + splat(0.f));
  return b ^ ((b >> 31) & i4{0x7fffffff, 0x7fffffff, 0x7fffffff, 0x7fffffff});
}

class ClusterBuilder;

// The builder. Primitive references live in two buffers: a node's are in
// buf_[side][b, e), and splitting it moves them, partitioned, to the same
// range of the other buffer (out of place: branch-free, where an in-place
// partition mispredicts about every other primitive once the order is
// scrambled). A leaf writes its ids straight into the output array.
class Builder {
 public:
  // Where a build writes: nodes (room for max(n - 1, 1) of them: a binary
  // tree over n leaves has n - 1 inner nodes at most; on more than one
  // thread, room for the threads' chunks' tails too, below) and the n
  // output references; how it numbers the nodes.
  //
  // Node numbers: on one thread, the nodes are numbered as they are made,
  // depth first. On more, every subtree of n primitives owns a range of
  // n - 1 numbers (as many inner nodes as it can have): its root takes the
  // first, its children's subtrees the next ones, in order. No shared
  // counter per node (its cache line would pass from core to core at every
  // node: measured, 2 threads no faster than 1 on the staircase); the
  // ranges' unused ends are gaps in the numbers (not in the storage, see
  // Out), which the renumbering (compact) closes. Every
  // subtree's range starts with its root and holds its left subtree's
  // range before its right one's, so the numbers are in depth-first order
  // already, gaps aside: the serial numbers are the ranks among the used
  // ones, marked in `used`.
  struct Out {
    BvhNode* nodes;
    uint32_t* prims;
    bool parallel;                      // more than one thread
    uint64_t* used = nullptr;           // on more: bit k set once node k is made (zeroed before)
    size_t capacity = 0;                // room in `nodes`
    std::atomic<uint32_t> next{0};      // on one thread: nodes made; on more: slots handed out
    std::atomic<uint32_t> depth{0};     // on one thread: the deepest inner node's depth (root: 1)

    // On more than one thread a node's number is not its place: the nodes
    // are stored densely, in the order each thread makes them, from slots
    // it takes kChunk at a time (a shared counter touched once per chunk),
    // each with its number in pad[0]; compact() puts them in number order.
    // (Stored at their numbers, with the ranges' gaps, they touched all
    // n - 1 slots' memory, 64 bytes per primitive, where the nodes take
    // about 28: on fresh memory, page faults. Measured, 2 threads, the
    // staircase: reused memory 16.8-17.1 -> 18.3-18.6 Mprims/s, fresh
    // memory 12.5-14.0 -> 13.4-17.1; Sponza fresh 10.9-12.9 -> 12.3-14.8.)
    // Left unused at the end: each thread's chunk's tail (mark_holes()). A
    // thread takes a new chunk only when its own is full, so the slots
    // handed out are the nodes plus at most kChunk per thread that took
    // part: bvh.nodes has room for the threads TBB may run
    // (global_control's max_allowed_parallelism, and the caller), and
    // slot() checks it all the same.
    struct Chunk {
      uint32_t pos = 0, end = 0;
    };
    static constexpr uint32_t kChunk = 64;
    // On more than one thread, each thread's: its chunk, the nodes it made
    // and the deepest one's depth (one lookup of the thread's entry per
    // node or small subtree: it hashes the thread's id).
    struct Local {
      Chunk chunk;
      uint32_t made = 0, deep = 0;
    };
    tbb::enumerable_thread_specific<Local> local{};

    // A new node's number and storage (its pad set; set_boxes and the
    // children fill the rest).
    struct Taken {
      uint32_t id;
      BvhNode* node;
    };
    // On more than one thread: storage for node `id`, from chunk c (the
    // calling thread's).
    BvhNode* slot(Chunk& c, uint32_t id) {
      if (c.pos == c.end) {
        const uint32_t pos = next.fetch_add(kChunk, std::memory_order_relaxed);
        if (size_t(pos) + kChunk > capacity) throw std::logic_error("build_bvh: node storage exhausted");
        c.pos = pos;
        c.end = pos + kChunk;
      }
      BvhNode* p = nodes + c.pos++;
      p->pad[0] = id;
      p->pad[1] = 0;
      return p;
    }
    // Node `id`'s storage: from chunk c on more than one thread (the
    // calling thread's), else its own slot.
    Taken place(uint32_t id, Chunk* c) {
      if (c) return {id, slot(*c, id)};
      nodes[id].pad[0] = nodes[id].pad[1] = 0;
      return {id, nodes + id};
    }
    // A new node at depth d, first of the range [at, ...) on more than one
    // thread.
    Taken take(uint32_t at, int d) {
      if (parallel) {
        Local& l = local.local();
        made_range(l, at, at + 1, d);
        return place(at, &l.chunk);
      }
      note_depth(d);
      const uint32_t k = next.load(std::memory_order_relaxed);
      next.store(k + 1, std::memory_order_relaxed);
      return place(k, nullptr);
    }
    // After a parallel build: the chunks' unused tails marked kHole.
    void mark_holes() {
      for (const Local& l : local)
        for (uint32_t i = l.chunk.pos; i < l.chunk.end; ++i) nodes[i].pad[0] = kHole;
    }
    // On more than one thread: nodes [b, e) made, the deepest at depth d.
    void made_range(Local& l, uint32_t b, uint32_t e, int d) {
      l.made += e - b;
      l.deep = std::max(l.deep, uint32_t(d));
      // Bits [b, e) of `used`; a word can be shared with another task's range.
      while (b < e) {
        const uint32_t w = b / 64, i = b % 64, len = std::min<uint32_t>(e - b, 64 - i);
        const uint64_t bits = (len == 64 ? ~uint64_t(0) : (uint64_t(1) << len) - 1) << i;
        std::atomic_ref<uint64_t>(used[w]).fetch_or(bits, std::memory_order_relaxed);
        b += len;
      }
    }
    void note_depth(int d) {
      depth.store(std::max(depth.load(std::memory_order_relaxed), uint32_t(d)), std::memory_order_relaxed);
    }
    // The number of nodes made.
    uint32_t count() {
      if (!parallel) return next.load();
      uint32_t c = 0;
      for (const Local& l : local) c += l.made;
      return c;
    }
    uint32_t max_depth() {
      if (!parallel) return depth.load();
      uint32_t d = 0;
      for (const Local& l : local) d = std::max(d, l.deep);
      return d;
    }
  };

  // The node numbers of a small subtree (taken in order, from its range on
  // more than one thread), their storage, and the depth of its deepest node.
  struct Block {
    Out& out;
    uint32_t next;
    Out::Chunk* chunk;  // on more than one thread: the calling thread's
    int depth = 0;
    Out::Taken take(int d) {
      depth = std::max(depth, d);
      return out.place(next++, chunk);
    }
  };

  // A builder over the n references in a (b: as much scratch space), whose
  // reference i goes to output slot first + i.
  Builder(PrimRef* a, PrimRef* b, size_t n, size_t first, Out& out, const BvhBuildOptions& opt)
      : buf_{a, b}, out_(out), n_(n), first_(first), opt_(opt) {
    nb_ = std::clamp(opt.bins, 2, kMaxBins);
    max_leaf_ = std::clamp<uint32_t>(opt.max_leaf_size, 1, kBvhMaxLeafSize);
    parallel_ = tbb::this_task_arena::max_concurrency() > 1;
  }

  // Builds the whole tree over buf_[0][0, n) (bounds box, centroid bounds
  // cbox) into out (root = index 0; a child's index is larger than its
  // parent's; depth-first order when built on one thread).
  void run(const Box& box, const Box& cbox) {
    if (n_ <= size_t(kSweepMax) && n_ > 1 && !opt_.median_split && !opt_.full_sweep) {
      small_subtree(buf_[0], int(n_), first_, box, 1, false, 0);  // not a leaf: the root, node 0
      return;
    }
    const Out::Taken root = out_.take(0, 1);
    if (n_ == 1) {
      // One primitive: a root whose second child is an empty leaf.
      set_boxes(*root.node, box, box);
      root.node->child[0] = make_leaf(0, 1, 0);
      root.node->child[1] = bvh_make_leaf(0, 0);
    } else {
      Split s;
      split(0, n_, 0, box, cbox, 1, false, s);
      fill(*root.node, 0, n_, 1, s, 1, 0);
    }
  }

  // The child reference for all n references (bounds box, centroid bounds
  // cbox) at depth `depth`, its nodes numbered from `at` (see Out): a leaf,
  // or a new inner node.
  uint32_t subtree(const Box& box, const Box& cbox, int depth, uint32_t at) {
    return make_child(0, n_, 0, box, cbox, depth, at);
  }

 private:
  friend class ClusterBuilder;  // for small_subtree

  PrimRef* buf_[2];
  Out& out_;
  size_t n_, first_;
  const BvhBuildOptions& opt_;
  int nb_;
  uint32_t max_leaf_;
  bool parallel_;  // more than one thread: partition large nodes in parallel too

  uint32_t make_leaf(size_t b, size_t e, int side) {
    const PrimRef* p = buf_[side];
    for (size_t i = b; i < e; ++i) out_.prims[first_ + i] = p[i].id();
    return bvh_make_leaf(uint32_t(first_ + b), uint32_t(e - b));
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
  // small_node for any size, by sorting (O(n log n) per node).
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

  // Two primitives (full_sweep only; small_node otherwise): split them, or
  // not, by the small subtrees' rules.
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

  // ------------------------------------------------------------ small subtrees
  //
  // Subtrees of at most kSweepMax primitives are built apart, with the exact
  // SAH sweep (the full_sweep reference's rule: every split between distinct
  // centroids) at every node. The primitives are sorted once on each axis,
  // at the subtree's root (a sorting network: sort_network); every node then
  // sweeps its three sorted lists and hands each child its part of them, in
  // order (a stable partition), so no node sorts again. A sorted list holds
  // the boxes themselves (SmallSet), so the sweeps read them in order.

  // The sorted lists of a small node: on axis a, lo[a][k] and hi[a][k] are
  // the box of the primitive with the k-th smallest centroid (ties: by
  // position in the buffer). lo's w lane holds the centroid on a (twice the
  // centre: no split may fall between equal ones), hi's w lane the
  // primitive's index in the subtree. A child's lists are a contiguous part
  // of its parent's.
  struct SmallSet {
    f4 lo[3][kSweepMax], hi[3][kSweepMax];
  };
  struct SmallView {
    f4 *lo[3], *hi[3];
    SmallView part(int k) const {
      return {{lo[0] + k, lo[1] + k, lo[2] + k}, {hi[0] + k, hi[1] + k, hi[2] + k}};
    }
  };
  static int small_index(f4 hi) { return std::bit_cast<int32_t>(hi[3]); }
  // The three lists' centroids at position k (lanes 0..2).
  static f4 centroids(const SmallView& v, int k) {
    f4 w = __builtin_shufflevector(v.lo[0][k], v.lo[1][k], 3, 7, 3, 7);
    return __builtin_shufflevector(w, v.lo[2][k], 0, 1, 7, 7);
  }

  // The child reference for the n ≤ kSweepMax primitives p[0, n) (bounds
  // box), whose leaves take output slots [first, first + n) and nodes the
  // numbers from `at` (see Out): sorts them, then builds their subtree
  // (small_node).
  uint32_t small_subtree(const PrimRef* p, const int n, size_t first, const Box& box, int depth, bool may_leaf,
                         uint32_t at) {
    l4 keys[kSweepMax];
    f4 cen[kSweepMax];
    for (int i = 0; i < n; ++i) {
      cen[i] = centroid2(p[i]);
      keys[i] = __builtin_convertvector(ordered(cen[i]), l4) << 32 | l4{i, i, i, i};
    }
    // The network of the next size up (4, 8, 12, 16, 24 or 32), the keys
    // padded to it.
    const int size = n <= 16 ? (n + 3) & ~3 : (n + 7) & ~7;
    const int64_t pad = std::numeric_limits<int64_t>::max();
    for (int i = n; i < size; ++i) keys[i] = l4{pad, pad, pad, pad};
    switch (size) {
      case 4: sort_network<4>(keys); break;
      case 8: sort_network<8>(keys); break;
      case 12: sort_network<12>(keys); break;
      case 16: sort_network<16>(keys); break;
      case 24: sort_network<24>(keys); break;
      default: sort_network<32>(keys); break;
    }
    SmallSet set;
    for (int k = 0; k < n; ++k)
      for (int a = 0; a < 3; ++a) {
        const int i = int(uint32_t(keys[k][a]));  // the low half: the index
        f4 lo = xyz(p[i].lo);
        lo[3] = cen[i][a];
        set.lo[a][k] = lo;
        set.hi[a][k] = (f4)((i4)p[i].hi | i4{0, 0, 0, i});
      }
    SmallView v{{set.lo[0], set.lo[1], set.lo[2]}, {set.hi[0], set.hi[1], set.hi[2]}};
    Out::Local* local = out_.parallel ? &out_.local.local() : nullptr;
    Block block{out_, out_.parallel ? at : out_.next.load(std::memory_order_relaxed),
                local ? &local->chunk : nullptr};
    const uint32_t start = block.next;
    const uint32_t root = small_node(v, n, p, first, box, depth, may_leaf, block);
    if (local) {
      out_.made_range(*local, start, block.next, block.depth);
    } else {
      out_.next.store(block.next, std::memory_order_relaxed);
      out_.note_depth(block.depth);
    }
    return root;
  }

  // small_node for two primitives (the commonest size by far), given their
  // entries in any list, without the sweeps and their set-up. Its result is
  // the sweep's: the one split there is (a box each side) costs the same on
  // every axis on which the centroids differ, so the sweep takes the first
  // such axis, or none (the costs are not below infinity, or no axis
  // separates the centroids): a leaf if allowed, else the median split on
  // axis 0. Either way in the order of that axis's list: by centroid, ties
  // by index.
  uint32_t small_pair(f4 lo0, f4 hi0, f4 lo1, f4 hi1, const PrimRef* p, size_t first, const Box& box, int depth,
                      bool may_leaf, Block& block) {
    const f4 c0 = xyz(lo0) + xyz(hi0), c1 = xyz(lo1) + xyz(hi1);
    const i4 differ = c0 != c1;
    // The same areas and sum as the sweep (half_areas3 per lane; x·1 = x).
    const float cost = half_area(lo0, hi0) + half_area(lo1, hi1);
    const bool splits = (differ[0] | differ[1] | differ[2]) && cost < kInf;
    const bool leaf = splits ? leaf_is_cheaper(2, cost, box, may_leaf) : may_leaf;
    const int axis = !splits || leaf ? 0 : differ[0] ? 0 : differ[1] ? 1 : 2;
    if (c1[axis] < c0[axis] || (c1[axis] == c0[axis] && small_index(hi1) < small_index(hi0)))
      std::swap(lo0, lo1), std::swap(hi0, hi1);
    out_.prims[first] = p[small_index(hi0)].id();
    out_.prims[first + 1] = p[small_index(hi1)].id();
    if (leaf) return bvh_make_leaf(uint32_t(first), 2);
    Box lbox, rbox;
    lbox.grow(lo0, hi0);
    rbox.grow(lo1, hi1);
    const auto [node, tp] = block.take(depth);
    BvhNode& t = *tp;
    set_boxes(t, lbox, rbox);
    t.child[0] = bvh_make_leaf(uint32_t(first), 1);
    t.child[1] = bvh_make_leaf(uint32_t(first + 1), 1);
    return node;
  }

  // The subtree of one or two primitives, given their entries lo/hi[0, n)
  // in a list (small_node without the other lists).
  uint32_t small_few(const f4* lo, const f4* hi, int n, const PrimRef* p, size_t first, const Box& box, int depth,
                     bool may_leaf, Block& block) {
    if (n == 2) return small_pair(lo[0], hi[0], lo[1], hi[1], p, first, box, depth, may_leaf, block);
    out_.prims[first] = p[small_index(hi[0])].id();
    return bvh_make_leaf(uint32_t(first), 1);
  }

  // The subtree over the sorted lists v (n primitives; their PrimRefs: p,
  // indexed as in the lists' w lanes), whose leaves take output slots
  // [first, first + n). Single primitives and pairs, half the calls, are
  // dispatched here, in the caller, without small_sweep's large frame.
  uint32_t small_node(const SmallView& v, int n, const PrimRef* p, size_t first, const Box& box, int depth,
                      bool may_leaf, Block& block) {
    if (n == 1 || (n == 2 && depth + 1 < kBvhStackSize - 2))
      return small_few(v.lo[0], v.hi[0], n, p, first, box, depth, may_leaf, block);
    return small_sweep(v, n, p, first, box, depth, may_leaf, block);
  }

  // small_node for n ≥ 2: the sweeps.
  uint32_t small_sweep(const SmallView& v, int n, const PrimRef* p, size_t first, const Box& box, int depth,
                       bool may_leaf, Block& block) {
    auto leaf = [&] {
      for (int k = 0; k < n; ++k) out_.prims[first + size_t(k)] = p[small_index(v.hi[0][k])].id();
      return bvh_make_leaf(uint32_t(first), uint32_t(n));
    };
    int axis = 0, nl = n / 2;  // the median, where no split separates centroids
    if (depth + int(std::bit_width(unsigned(n - 1))) < kBvhStackSize - 2) {
      // The sweep on all three axes at once (lane a = axis a). First from
      // the right: right_cost[k], the area of [k, n) times its count, or
      // +inf where no split may fall before k (centroids k - 1 and k are
      // equal), so that the loop from the left, the one that keeps the
      // best, carries fewer values (it ran out of registers).
      f4 right_cost[kSweepMax];
      {
        f4 lx = splat(kInf), ly = lx, lz = lx, hx = splat(-kInf), hy = hx, hz = hx;
        f4 nr4 = splat(1.f), cen = centroids(v, n - 1);
        for (int k = n - 1; k > 0; --k) {
          lx = min4(lx, v.lo[0][k]), hx = max4(hx, v.hi[0][k]);
          ly = min4(ly, v.lo[1][k]), hy = max4(hy, v.hi[1][k]);
          lz = min4(lz, v.lo[2][k]), hz = max4(hz, v.hi[2][k]);
          const f4 prev = centroids(v, k - 1), c = half_areas3(hx - lx, hy - ly, hz - lz) * nr4;
          right_cost[k] = prev < cen ? c : splat(kInf);
          cen = prev;
          nr4 += splat(1.f);
        }
      }
      f4 lx = splat(kInf), ly = lx, lz = lx, hx = splat(-kInf), hy = hx, hz = hx;
      f4 best = splat(kInf);
      // The left side's count (exact in floats); best_nl: the best split's
      // left count (0: none yet).
      f4 nl4 = splat(1.f), best_nl = splat(0.f);
      for (int k = 0; k < n - 1; ++k) {
        lx = min4(lx, v.lo[0][k]), hx = max4(hx, v.hi[0][k]);
        ly = min4(ly, v.lo[1][k]), hy = max4(hy, v.hi[1][k]);
        lz = min4(lz, v.lo[2][k]), hz = max4(hz, v.hi[2][k]);
        const f4 c = half_areas3(hx - lx, hy - ly, hz - lz) * nl4 + right_cost[k + 1];
        const i4 better = c < best;
        best = better ? c : best;
        best_nl = better ? nl4 : best_nl;
        nl4 += splat(1.f);
      }
      axis = 0;
      if (best[1] < best[axis]) axis = 1;
      if (best[2] < best[axis]) axis = 2;
      if (best_nl[axis] > 0.f) {
        if (leaf_is_cheaper(size_t(n), best[axis], box, may_leaf)) return leaf();
        nl = int(best_nl[axis]);
      } else {
        // All centroids coincide: a leaf if allowed, else the median.
        if (may_leaf) return leaf();
        axis = 0;
      }
    } else if (may_leaf) {
      return leaf();
    } else {
      // The depth guard: the median on the widest centroid axis.
      f4 ext = (v.lo[0][n - 1] + v.hi[0][n - 1]) - (v.lo[0][0] + v.hi[0][0]);
      ext[1] = (v.lo[1][n - 1][1] + v.hi[1][n - 1][1]) - (v.lo[1][0][1] + v.hi[1][0][1]);
      ext[2] = (v.lo[2][n - 1][2] + v.hi[2][n - 1][2]) - (v.lo[2][0][2] + v.hi[2][0][2]);
      axis = ext[0] >= ext[1] ? (ext[0] >= ext[2] ? 0 : 2) : (ext[1] >= ext[2] ? 1 : 2);
    }

    Box lbox, rbox;
    for (int k = 0; k < nl; ++k) lbox.grow(v.lo[axis][k], v.hi[axis][k]);
    for (int k = nl; k < n; ++k) rbox.grow(v.lo[axis][k], v.hi[axis][k]);
    if (nl <= 2 && n - nl <= 2 && depth + 2 < kBvhStackSize - 2) {
      // Children of one or two primitives (a third of the splits) need
      // their entries in this list only: no partition.
      const auto [node, tp] = block.take(depth);
      BvhNode& t = *tp;
      set_boxes(t, lbox, rbox);
      const f4 *lo = v.lo[axis], *hi = v.hi[axis];
      t.child[0] = small_few(lo, hi, nl, p, first, lbox, depth + 1, size_t(nl) <= max_leaf_, block);
      t.child[1] = small_few(lo + nl, hi + nl, n - nl, p, first + size_t(nl), rbox, depth + 1,
                             size_t(n - nl) <= max_leaf_, block);
      return node;
    }

    // Split the lists: the first nl on `axis` go left, so that list is split
    // as it is (the children point into it); the other two axes' lists are
    // partitioned stably into `child` (branch-free, each entry written once).
    SmallSet child;
    const int a1 = axis == 0 ? 1 : 0, a2 = axis == 2 ? 1 : 2;
    SmallView cv;
    cv.lo[axis] = v.lo[axis], cv.hi[axis] = v.hi[axis];
    cv.lo[a1] = child.lo[a1], cv.hi[a1] = child.hi[a1];
    cv.lo[a2] = child.lo[a2], cv.hi[a2] = child.hi[a2];
    uint64_t left = 0;  // bit i: primitive i goes left
    for (int k = 0; k < nl; ++k) left |= uint64_t(1) << small_index(v.hi[axis][k]);
    int l1 = 0, r1 = nl, l2 = 0, r2 = nl;
    for (int k = 0; k < n; ++k) {
      f4 lo1 = v.lo[a1][k], hi1 = v.hi[a1][k], lo2 = v.lo[a2][k], hi2 = v.hi[a2][k];
      int in1 = int(left >> small_index(hi1)) & 1, in2 = int(left >> small_index(hi2)) & 1;
      int at1 = r1 ^ ((l1 ^ r1) & -in1), at2 = r2 ^ ((l2 ^ r2) & -in2);  // in ? l : r, as in partition()
      child.lo[a1][at1] = lo1, child.hi[a1][at1] = hi1;
      child.lo[a2][at2] = lo2, child.hi[a2][at2] = hi2;
      l1 += in1, r1 += 1 - in1;
      l2 += in2, r2 += 1 - in2;
    }
    const auto [node, tp] = block.take(depth);
    BvhNode& t = *tp;
    set_boxes(t, lbox, rbox);
    t.child[0] = small_node(cv, nl, p, first, lbox, depth + 1, size_t(nl) <= max_leaf_, block);
    t.child[1] = small_node(cv.part(nl), n - nl, p, first + size_t(nl), rbox, depth + 1, size_t(n - nl) <= max_leaf_,
                            block);
    return node;
  }

  // Branch-free partition of src[b, e) into dst: the left side (test.left
  // of the centroid on `axis`) to dst[l, ...), the right side to dst[r, ...),
  // both in their order in src. The boundary is known beforehand (from the
  // bin counts), so each primitive is written once, to the end its side
  // picks.
  static void partition(const PrimRef* src, PrimRef* dst, size_t b, size_t e, size_t l, size_t r,
                        Binner::SideTest test, int axis) {
    for (size_t i = b; i < e; ++i) {
      const PrimRef& x = src[i];
      size_t left = size_t(test.left(x.lo[axis] + x.hi[axis]));
      // dst[left ? l : r], as arithmetic: compilers turn the ?: into a
      // branch, mispredicted about every other primitive.
      dst[r ^ ((l ^ r) & (0 - left))] = x;
      l += left;
      r += 1 - left;
    }
  }

  // The same over a large node, in parallel: blocks count their left
  // primitives, then each partitions its part to where the blocks before it
  // end. The result is the serial partition's, whatever the thread count.
  static void parallel_partition(const PrimRef* src, PrimRef* dst, size_t b, size_t e, size_t mid,
                                 Binner::SideTest test, int axis) {
    const std::vector<size_t> left_before = left_before_blocks(src, b, e, test, axis);
    const size_t blocks = left_before.size() - 1;
    tbb::parallel_for(size_t(0), blocks, [&](size_t k) {
      size_t i0 = b + k * kPartitionBlock, i1 = std::min(e, i0 + kPartitionBlock);
      partition(src, dst, i0, i1, b + left_before[k], mid + (i0 - b - left_before[k]), test, axis);
    });
  }

  // Best SAH split of [b, e) in buf_[side] (bounds box, centroid bounds
  // cbox). Returns false when a leaf is no more expensive (only if
  // may_leaf); else moves the primitives to the other buffer and fills s.
  bool split(size_t b, size_t e, int side, const Box& box, const Box& cbox, int depth, bool may_leaf, Split& s,
             bool exact_cbox = false) {
    size_t n = e - b;
    if (opt_.median_split || depth + int(std::bit_width(n - 1)) >= kBvhStackSize - 2)
      return unsplittable(b, e, side, cbox, may_leaf, s);
    if (opt_.full_sweep && n > 2) return full_sweep_split(b, e, side, box, cbox, may_leaf, s);
    if (n == 2) return pair_split(b, side, box, may_leaf, s);
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
    bin_all(bn, src, b, e, nb, bins);
    int axis, last;
    float best;
    if (!sweep_bins(bins, nb, bn.axis_ok(), axis, last, best)) {
      // Extreme clustering: bin again over the exact centroid bounds
      // (tighter_centroid_bounds) before giving up.
      Box exact;
      if (!exact_cbox && tighter_centroid_bounds(src, b, e, cbox, exact))
        return split(b, e, side, box, exact, depth, may_leaf, s, true);
      return unsplittable(b, e, side, cbox, may_leaf, s);
    }
    if (leaf_is_cheaper(size_t(n), best, box, may_leaf)) return false;

    size_t nl = 0;
    for (int i = 0; i <= last; ++i) {
      s.lbox.grow(bins.lo[axis][i], bins.hi[axis][i]);
      nl += size_t(bins.count(i)[axis]);
    }
    for (int i = last + 1; i < nb; ++i) s.rbox.grow(bins.lo[axis][i], bins.hi[axis][i]);
    s.mid = b + nl;
    if (n >= kParallelBinning && parallel_)
      parallel_partition(src, buf_[side ^ 1], b, e, s.mid, bn.side_test(axis, last), axis);
    else
      partition(src, buf_[side ^ 1], b, e, b, s.mid, bn.side_test(axis, last), axis);
    // The children's centroid bounds, without a pass over them: a
    // primitive's box holds its centroid, so each side's centroids lie in the
    // union of its bins' boxes (doubled: centroid2), and in the parent's
    // centroid bounds. Looser than the exact bounds by about half a
    // primitive, which only spreads the children's bins a little.
    s.lcbox.lo = max4(cbox.lo, s.lbox.lo + s.lbox.lo), s.lcbox.hi = min4(cbox.hi, s.lbox.hi + s.lbox.hi);
    s.rcbox.lo = max4(cbox.lo, s.rbox.lo + s.rbox.lo), s.rcbox.hi = min4(cbox.hi, s.rbox.hi + s.rbox.hi);
    return true;
  }

  // Child reference for [b, e) in buf_[side]: a leaf, or a new inner node.
  uint32_t make_child(size_t b, size_t e, int side, const Box& box, const Box& cbox, int depth, uint32_t at) {
    size_t n = e - b;
    if (n <= 1) return make_leaf(b, e, side);
    if (n <= size_t(kSweepMax) && !opt_.median_split && !opt_.full_sweep)
      return small_subtree(buf_[side] + b, int(n), first_ + b, box, depth, n <= max_leaf_, at);
    Split s;
    if (!split(b, e, side, box, cbox, depth, n <= max_leaf_, s)) return make_leaf(b, e, side);
    const Out::Taken node = out_.take(at, depth);
    fill(*node.node, b, e, side ^ 1, s, depth, at);
    return node.id;
  }

  // Fills inner node t split by s; its children are in buf_[side].
  // (Its numbers from `at`: the children's ranges follow.)
  void fill(BvhNode& t, size_t b, size_t e, int side, const Split& s, int depth, uint32_t at) {
    const uint32_t lat = at + 1, rat = at + uint32_t(s.mid - b);
    set_boxes(t, s.lbox, s.rbox);
    if (e - b >= kParallelSubtree && parallel_) {
      tbb::parallel_invoke([&] { t.child[0] = make_child(b, s.mid, side, s.lbox, s.lcbox, depth + 1, lat); },
                           [&] { t.child[1] = make_child(s.mid, e, side, s.rbox, s.rcbox, depth + 1, rat); });
    } else {
      t.child[0] = make_child(b, s.mid, side, s.lbox, s.lcbox, depth + 1, lat);
      t.child[1] = make_child(s.mid, e, side, s.rbox, s.rcbox, depth + 1, rat);
    }
  }
};

// Large build arrays on transparent huge pages where the kernel gives them
// only on request (THP "madvise" mode): the build touches about 130 bytes per
// primitive of fresh memory, and on 4 KiB pages the page faults cost as much
// as the build itself above a million primitives (measured on a VM: 1.06M
// triangles, ~40% of the time). Advises the 2 MiB-aligned interior of
// [p, p + bytes) before its first touch; a no-op elsewhere.
constexpr size_t kHugePage = size_t(2) << 20;

void advise_huge(void* p, size_t bytes) {
#if defined(MADV_HUGEPAGE)
  if (bytes < 2 * kHugePage) return;
  uintptr_t b = (reinterpret_cast<uintptr_t>(p) + kHugePage - 1) & ~(kHugePage - 1);
  uintptr_t e = (reinterpret_cast<uintptr_t>(p) + bytes) & ~(kHugePage - 1);
  if (e > b) madvise(reinterpret_cast<void*>(b), e - b, MADV_HUGEPAGE);
#else
  (void)p, (void)bytes;
#endif
}

}  // namespace

void* build_allocate(size_t bytes, size_t align) {
  bytes = std::max<size_t>(bytes, 1);
  if (bytes >= 2 * kHugePage) align = std::max(align, kHugePage);
  void* p = ::operator new(bytes, std::align_val_t(align));
  advise_huge(p, bytes);
  return p;
}

void build_deallocate(void* p, size_t bytes, size_t align) noexcept {
  bytes = std::max<size_t>(bytes, 1);
  if (bytes >= 2 * kHugePage) align = std::max(align, kHugePage);
  ::operator delete(p, std::align_val_t(align));
}

namespace {

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

// ------------------------------------------------------------ clusters
//
// Above the small subtrees, the binned SAH bins clusters of up to
// kClusterMax primitives instead of primitives (BvhBuildOptions::clusters),
// so that those levels touch a few times fewer references. The primitives
// are sorted once by the Morton codes of their centroids (kMortonBits per
// axis over the cube around the centroid bounds; three radix passes), and
// the sorted list is cut into cells of the codes' binary radix tree (make_clusters): each
// cluster is the largest cell around its primitives that holds at most
// kClusterMax of them and spans at most 2^-kClusterLevel of the grid's
// side. More than kClusterMax primitives in one cell of the grid
// are ordered by codes over their own bounds first (refine_run; the
// staircase has 57% of its triangles in such runs). Two rules keep
// clusters tight: a primitive more than kLargeFactor larger (in area) than
// the rest of its cluster together leaves it for a cluster of its own (a
// long triangle would otherwise drag small ones along), and a cluster more
// than kDissolve larger than its cell (long primitives crossing each other)
// is split into its primitives, which only binning them one by one
// separates. The clusters are binned and partitioned like primitives (their
// boxes and centres; each counts for its primitives in the SAH), with about
// two per bin in small nodes. A node of at most kClusterSweep (16)
// primitives gathers its clusters' primitives and builds its subtree
// exactly, as the primitive builder does; so does one of at most kSweepMax
// (32) in clusters of fewer than two primitives on average, where binning
// saves little and loses more (long crossing primitives, which the rules
// above leave alone). Against handing over every node of at most 32:
// 9% fewer instructions on Sponza, 11% on the staircase, SAH cost -0.01%
// and -0.08% (only 16: +0.03% and -0.16%, but +1.2% on the crossing
// triangles of LooseCentroidBoundsStillSplitBySah).
//
// Measured against the primitive builder (SAH cost averaged over 9..32
// bins, as it varies by a few % from one bin count to the next; before the
// cubes below): Sponza -0.2%, Sponza tiled 4× +0.4%, the staircase +0.3%,
// the Stanford bunny +0.6%, the dense spots of
// ClustersOnDenseSpotsInALargeScene 0.0% (globally; inside the spots, see
// below). With the cubes: Sponza -0.24%, the staircase +0.01%. Cells
// of 2^-6 instead of 2^-7 build ~5% faster but cost +2% on the tiled Sponza
// and the bunny; clusters of 8 with neither the cell limit nor the rules
// above cost +3% to +4% everywhere.
//
// The grid's cells are cubes (cube()). Over the centroid bounds axis by
// axis, a scene much flatter than wide had cells hundreds of times longer
// than high, and a small dense object in it was cut into slabs: clusters
// spanning the object, which no split below them could separate (the
// dense spots of ClustersOnDenseSpotsInALargeScene, cells 600 times longer
// than high: SAH cost inside the spots 2.5× the primitive builder's; with
// cubes 1.07×). SAH cost averaged over 9..32 bins, axis by axis -> cubes:
// Sponza 68.077 -> 68.051, the staircase 45.399 -> 45.354 (at 32 bins
// alone: 68.166 -> 68.532 and 45.373 -> 45.076); the build's speed the
// same. Where the centroid bounds are not finite (far beyond FLT_MAX
// apart), the grid stays axis by axis, as before.

constexpr int kMortonBits = 10;                    // per axis
constexpr int kClusterMax = 16;                    // primitives per cluster at most
constexpr int kClusterLevel = 7;                   // cells at most 2^-7 of the grid's side ...
constexpr int kClusterPrefix = 3 * kClusterLevel;  // ... whose codes share this many bits
constexpr float kLargeFactor = 2.f;                // half areas: a primitive / the rest of its cluster
constexpr float kDissolve = 1024.f;                // half areas: a cluster / its cell
constexpr int kClusterSweep = 16;                  // nodes of at most this many primitives: exact
static_assert(kClusterMax <= kClusterSweep && kClusterSweep <= kSweepMax);

// The cube at cb's low corner whose side is cb's largest extent: the Morton
// grids' bounds, so that their cells are cubes.
inline Box cube(const Box& cb) {
  const f4 e = xyz(cb.hi) - xyz(cb.lo);
  const float side = std::max(e[0], std::max(e[1], e[2]));
  Box c;
  c.lo = xyz(cb.lo);
  c.hi = c.lo + f4{side, side, side, 0.f};
  // Extents or corners not finite (or NaN): the bounds as they are, so
  // that the finite axes keep their bins.
  const float big = std::numeric_limits<float>::max();
  for (int a = 0; a < 3; ++a)
    if (!(e[a] <= big) || !(std::fabs(c.hi[a]) <= big)) return cb;
  return c;
}

// v's kMortonBits bits spread to every third bit (bit i to bit 3i).
constexpr std::array<uint32_t, 1 << kMortonBits> make_spread() {
  std::array<uint32_t, 1 << kMortonBits> t{};
  for (uint32_t v = 0; v < t.size(); ++v)
    for (int b = 0; b < kMortonBits; ++b) t[v] |= ((v >> b) & 1u) << (3 * b);
  return t;
}
constexpr std::array<uint32_t, 1 << kMortonBits> kSpread = make_spread();

// A key: a Morton code in the high 32 bits, a reference's index below.
inline uint32_t code_of(uint64_t key) { return uint32_t(key >> 32); }

// The Morton code of a point given its bins on the three axes.
inline uint32_t morton(i4 q) { return kSpread[q[0]] << 2 | kSpread[q[1]] << 1 | kSpread[q[2]]; }

// Runs fn(b, e, k) over the blocks [b, e) = [k·block, (k + 1)·block) ∩ [0, n),
// in parallel if `parallel`.
template <class F>
void for_blocks(size_t n, size_t block, bool parallel, const F& fn) {
  const size_t blocks = (n + block - 1) / block;
  if (parallel && blocks > 1)
    tbb::parallel_for(size_t(0), blocks, [&](size_t k) { fn(k * block, std::min(n, (k + 1) * block), k); });
  else
    for (size_t k = 0; k < blocks; ++k) fn(k * block, std::min(n, (k + 1) * block), k);
}

constexpr size_t kDigits = size_t(1) << kMortonBits;
constexpr size_t kSortBlock = size_t(1) << 14;  // keys per block of the parallel passes (at least)

// The block size of the parallel passes over n keys: at most 256 blocks, so
// that the radix passes' histograms stay small.
inline size_t sort_block(size_t n) { return std::max(kSortBlock, (n + 255) / 256); }

// One stable radix pass on the kMortonBits bits of the keys above bit
// `shift`, src[0, n) to dst. hist: the digits' counts per block of `block`
// keys, turned into offsets here.
void radix_pass(const uint64_t* src, uint64_t* dst, size_t n, size_t block, int shift, uint32_t* hist, bool parallel) {
  const size_t blocks = (n + block - 1) / block;
  uint32_t sum = 0;
  for (size_t d = 0; d < kDigits; ++d)
    for (size_t k = 0; k < blocks; ++k) sum += std::exchange(hist[k * kDigits + d], sum);
  for_blocks(n, block, parallel, [&](size_t b, size_t e, size_t k) {
    uint32_t* h = hist + k * kDigits;
    for (size_t i = b; i < e; ++i) dst[h[(src[i] >> shift) & (kDigits - 1)]++] = src[i];
  });
}

// Reorders sorted[0, m), primitives whose codes are equal (more than
// kClusterMax centroids within one cell of the grid), by Morton codes over
// the cube around their own centroid bounds, and sets the depths d[1, m)
// of the splits between them (32 + their common prefix depth: deeper than
// any split of the grid). keys[0, m): scratch. Coinciding centroids are
// left as they are. (On the sorted primitives, not through the keys'
// indices: the staircase's 3,900 runs then read memory in order, not at
// random.)
void refine_run(uint64_t* keys, PrimRef* sorted, size_t m, uint8_t* d) {
  Box cb;
  for (size_t i = 0; i < m; ++i) cb.grow(centroid2(sorted[i]));
  const Binner grid(cube(cb), 1 << kMortonBits);
  if (grid.degenerate()) return;
  for (size_t i = 0; i < m; ++i) keys[i] = uint64_t(morton(grid.bin(centroid2(sorted[i])))) << 32 | i;
  // The run's copy on the stack (the staircase's runs: 17 to 297
  // primitives, 3 of them over 256), on the heap if longer.
  constexpr size_t kLocal = 256;
  PrimRef local[kLocal];
  std::vector<PrimRef> heap;
  const PrimRef* run = local;
  if (m <= kLocal) {
    std::copy(sorted, sorted + m, local);
  } else {
    heap.assign(sorted, sorted + m);
    run = heap.data();
  }
  // Up to kRankMax primitives (nearly all runs), each key's place is its
  // rank, the number of smaller keys (they are distinct: their low bits
  // are the indices), counted without a branch (vectorised): std::sort's
  // comparisons mispredict about every other time on such short runs.
  // 1-thread staircase build 10.2-10.4 -> 11.0-11.1 Mprims/s (64 or 256:
  // 10.9). Same order, same tree.
  constexpr size_t kRankMax = 128;
  if (m <= kRankMax) {
    uint32_t codes[kRankMax];
    const int64_t* k = reinterpret_cast<const int64_t*>(keys);  // below 2^62: signed order is theirs
    for (size_t i = 0; i < m; ++i) {
      uint32_t r = 0;
      for (size_t j = 0; j < m; ++j) r += uint32_t(k[j] < k[i]);
      sorted[r] = run[i];
      codes[r] = code_of(keys[i]);
    }
    for (size_t i = 1; i < m; ++i) d[i] = uint8_t(32 + std::countl_zero(codes[i - 1] ^ codes[i]));
    return;
  }
  std::sort(keys, keys + m);
  for (size_t i = 0; i < m; ++i) sorted[i] = run[uint32_t(keys[i])];
  for (size_t i = 1; i < m; ++i) d[i] = uint8_t(32 + std::countl_zero(code_of(keys[i - 1]) ^ code_of(keys[i])));
}

// A cluster: its first position in the sorted keys, and the depth of its
// cell (see make_clusters; 255 for a single primitive).
struct Cut {
  uint32_t start;
  uint8_t depth;
};

// Cuts the primitives sorted[0, n), in the order of their keys[0, n) (the
// sorted codes of their centroids), into clusters: writes them to
// cuts[0, ...) (room for n) and returns their number (d[0, n]: scratch). The
// cluster that starts at b is the largest radix-tree cell [b, e) within the
// limits: no more than kClusterMax primitives, no shallower than
// kClusterPrefix bits (the single primitive [b, b + 1) always qualifies).
// [b, e) is a cell when every split inside it (between i - 1 and i, at the
// depth of their codes' common prefix, d[i]) is deeper than the splits at
// its ends, d[b] and d[e]: the top-down cut of the radix tree, in one pass.
// Runs of more than kClusterMax equal codes are first reordered within
// their cell (refine_run; the keys are then scratch); coinciding centroids
// split nowhere, and more than kClusterMax of them become clusters of one,
// for the binned SAH. On more than one thread, each pass runs in blocks;
// the greedy cut restarts at splits shallower than kClusterPrefix, which
// are always cuts, so the result is the serial one.
size_t make_clusters(uint64_t* keys, PrimRef* sorted, size_t n, uint8_t* d, Cut* cuts, bool parallel) {
  // d[i]: the common-prefix depth of codes i - 1 and i in their 32-bit word
  // (the codes have 2 leading zeros, so d ≥ 2; 32 where equal); 0 at the
  // ends.
  d[0] = d[n] = 0;
  const size_t block = sort_block(n);
  for_blocks(n, block, parallel, [&](size_t b, size_t e, size_t) {
    // (The bit below the code makes the count 32 for equal codes, without
    // a branch.)
    for (size_t i = std::max<size_t>(b, 1); i < e; ++i)
      d[i] = uint8_t(std::countl_zero(uint64_t(code_of(keys[i - 1]) ^ code_of(keys[i])) << 32 | 1u << 31));
  });
  // Runs of more than kClusterMax equal codes, ordered within their cell.
  std::vector<std::pair<size_t, size_t>> runs;
  for (size_t i = 1; i < n;) {
    const void* at = std::memchr(d + i, 32, n - i);
    if (!at) break;
    i = size_t(static_cast<const uint8_t*>(at) - d);
    size_t j = i + 1;
    while (j < n && d[j] == 32) ++j;
    if (j - (i - 1) > size_t(kClusterMax)) runs.push_back({i - 1, j});
    i = j + 1;
  }
  for_blocks(runs.size(), 1, parallel, [&](size_t r, size_t, size_t) {
    refine_run(keys + runs[r].first, sorted + runs[r].first, runs[r].second - runs[r].first, d + runs[r].first);
  });

  // The greedy cut of [b, e) (b: a cut) into out[0, ...) (at most e - b
  // cuts); returns their number.
  constexpr int kMinDepth = 32 - 3 * kMortonBits + kClusterPrefix;
  auto cut = [&](size_t b, size_t e, Cut* out) {
    size_t count = 0;
    while (b < e) {
      const int db = d[b];
      const size_t last = std::min(e, b + size_t(kClusterMax));
      size_t end = b + 1;
      int inner = 255, depth = 255;  // the shallowest split inside [b, x), and inside [b, end)
      for (size_t x = b + 2; x <= last; ++x) {
        inner = std::min<int>(inner, d[x - 1]);
        if (inner <= db || inner < kMinDepth) break;  // no larger cell starts at b
        if (d[x] < inner) end = x, depth = inner;
      }
      out[count++] = {uint32_t(b), uint8_t(depth)};
      b = end;
    }
    return count;
  };
  if (!parallel) return cut(0, n, cuts);
  const size_t blocks = (n + block - 1) / block;
  std::vector<size_t> from(blocks + 1, n);  // block k cuts [from[k], from[k + 1])
  for_blocks(blocks, 1, true, [&](size_t k, size_t, size_t) {
    size_t i = k * block;
    while (i > 0 && i < n && d[i] >= kMinDepth) ++i;
    from[k] = i;
  });
  // Block k's cuts from cuts[from[k]] (no more than its primitives), then
  // moved down together, in order.
  std::vector<size_t> made(blocks);
  for_blocks(blocks, 1, true, [&](size_t k, size_t, size_t) { made[k] = cut(from[k], from[k + 1], cuts + from[k]); });
  size_t total = 0;
  for (size_t k = 0; k < blocks; ++k) {
    std::memmove(cuts + total, cuts + from[k], made[k] * sizeof(Cut));
    total += made[k];
  }
  return total;
}

// The binned SAH over clusters (the top of the tree). A cluster reference
// is a PrimRef: the cluster's box, the position of its first primitive in
// the sorted list in lo's w lane, kCountBase + its number of primitives in
// hi's w lane (so the bins count primitives). The references live in two
// buffers like the Builder's primitives, but the partition sends the right
// side to the end of the range in reverse order: the bins count the
// primitives on each side, not the clusters.
class ClusterBuilder {
 public:
  // Clusters c0[0, count) (c1: as much scratch space) of the primitives
  // sorted[0, n).
  ClusterBuilder(PrimRef* c0, PrimRef* c1, const PrimRef* sorted, Builder::Out& out, const BvhBuildOptions& opt)
      : cl_{c0, c1}, sorted_(sorted), out_(out), opt_(opt), small_(nullptr, nullptr, 0, 0, out, opt) {
    nb_ = std::clamp(opt.bins, 2, kMaxBins);
    max_leaf_ = std::clamp<uint32_t>(opt.max_leaf_size, 1, kBvhMaxLeafSize);
    parallel_ = tbb::this_task_arena::max_concurrency() > 1;
  }

  // Builds the tree over `count` clusters holding n > kSweepMax primitives
  // (bounds box, cluster centroid bounds cbox).
  void run(size_t count, size_t n, const Box& box, const Box& cbox) {
    node(0, count, 0, 0, n, box, cbox, 1, 0);  // n > kSweepMax: an inner node, node 0
  }

 private:
  PrimRef* cl_[2];
  const PrimRef* sorted_;
  Builder::Out& out_;
  const BvhBuildOptions& opt_;
  Builder small_;  // no buffers: its small_subtree only
  int nb_;
  uint32_t max_leaf_;
  bool parallel_;

  static uint32_t size(const PrimRef& c) { return uint32_t(std::bit_cast<int32_t>(c.hi[3]) - kCountBase); }

  // The primitives of clusters cl_[side][cb, ce), in order, to `to`.
  void gather(size_t cb, size_t ce, int side, PrimRef* to) const {
    for (size_t c = cb; c < ce; ++c) {
      const PrimRef* p = sorted_ + cl_[side][c].id();
      for (uint32_t i = 0, m = size(cl_[side][c]); i < m; ++i) *to++ = p[i];
    }
  }

  // Partition of src[b, e) into dst: the left side to dst[l, ...) in order,
  // the right side to dst[..., r] from r down. Returns the left side's end.
  static size_t partition(const PrimRef* src, PrimRef* dst, size_t b, size_t e, size_t l, size_t r,
                          Binner::SideTest test, int axis) {
    for (size_t i = b; i < e; ++i) {
      const PrimRef& x = src[i];
      size_t left = size_t(test.left(x.lo[axis] + x.hi[axis]));
      dst[r ^ ((l ^ r) & (0 - left))] = x;  // as in Builder::partition
      l += left;
      r -= 1 - left;
    }
    return l;
  }

  // The same over a large range, in parallel (the serial result).
  static size_t parallel_partition(const PrimRef* src, PrimRef* dst, size_t b, size_t e, Binner::SideTest test,
                                   int axis) {
    const std::vector<size_t> left_before = left_before_blocks(src, b, e, test, axis);
    const size_t blocks = left_before.size() - 1;
    tbb::parallel_for(size_t(0), blocks, [&](size_t k) {
      size_t i0 = b + k * kPartitionBlock, i1 = std::min(e, i0 + kPartitionBlock);
      partition(src, dst, i0, i1, b + left_before[k], e - 1 - (i0 - b - left_before[k]), test, axis);
    });
    return b + left_before[blocks];
  }

  // The primitives of clusters cl_[side][cb, ce) (output slots [pb, pe))
  // built by the primitive Builder: where no plane separates the clusters,
  // and near the depth limit.
  uint32_t fallback(size_t cb, size_t ce, int side, size_t pb, size_t pe, const Box& box, int depth, uint32_t at) {
    const size_t n = pe - pb;
    std::vector<PrimRef> a(n), s(n);
    gather(cb, ce, side, a.data());
    Box cbox;
    for (const PrimRef& r : a) cbox.grow(centroid2(r));
    return Builder(a.data(), s.data(), n, pb, out_, opt_).subtree(box, cbox, depth, at);
  }

  // The child reference for clusters cl_[side][cb, ce), holding the
  // primitives of output slots [pb, pe) (bounds box, cluster centroid bounds
  // cbox), at depth `depth`, its nodes numbered from `at` (see Builder::Out).
  uint32_t node(size_t cb, size_t ce, int side, size_t pb, size_t pe, const Box& box, const Box& cbox, int depth,
                uint32_t at, bool exact_cbox = false) {
    const size_t n = pe - pb, m = ce - cb;
    if (n <= size_t(kClusterSweep) || (n <= size_t(kSweepMax) && 2 * m > n)) {  // see kClusterSweep
      // One cluster: its primitives are already contiguous in sorted_.
      if (m == 1) return small_.small_subtree(sorted_ + cl_[side][cb].id(), int(n), pb, box, depth, n <= max_leaf_, at);
      PrimRef p[kSweepMax];
      gather(cb, ce, side, p);
      return small_.small_subtree(p, int(n), pb, box, depth, n <= max_leaf_, at);
    }
    if (depth + int(std::bit_width(n - 1)) >= kBvhStackSize - 2) return fallback(cb, ce, side, pb, pe, box, depth, at);
    // Bins: about two clusters each in small nodes (measured: no change in
    // SAH cost, 3% faster than one each).
    const int nb = int(std::min<size_t>(size_t(nb_), std::max<size_t>(m / 2, 2)));
    Binner bn(cbox, nb);
    if (bn.degenerate()) return fallback(cb, ce, side, pb, pe, box, depth, at);
    const PrimRef* src = cl_[side];
    Bins bins;
    bin_all<true>(bn, src, cb, ce, nb, bins, kParallelClusters);
    int axis, last;
    float best;
    if (!sweep_bins(bins, nb, bn.axis_ok(), axis, last, best)) {
      // As in Builder::split: bin again over the exact centroid bounds.
      Box exact;
      if (!exact_cbox && tighter_centroid_bounds(src, cb, ce, cbox, exact))
        return node(cb, ce, side, pb, pe, box, exact, depth, at, true);
      return fallback(cb, ce, side, pb, pe, box, depth, at);
    }
    Box lbox, rbox;
    size_t nl = 0;
    for (int i = 0; i <= last; ++i) {
      lbox.grow(bins.lo[axis][i], bins.hi[axis][i]);
      nl += size_t(bins.count(i)[axis]);
    }
    for (int i = last + 1; i < nb; ++i) rbox.grow(bins.lo[axis][i], bins.hi[axis][i]);
    PrimRef* dst = cl_[side ^ 1];
    const size_t mid = m >= kParallelClusters && parallel_
                           ? parallel_partition(src, dst, cb, ce, bn.side_test(axis, last), axis)
                           : partition(src, dst, cb, ce, cb, ce - 1, bn.side_test(axis, last), axis);
    // The children's centroid bounds from the bins, as in Builder::split (a
    // cluster's centre lies in its box).
    Box lcbox, rcbox;
    lcbox.lo = max4(cbox.lo, lbox.lo + lbox.lo), lcbox.hi = min4(cbox.hi, lbox.hi + lbox.hi);
    rcbox.lo = max4(cbox.lo, rbox.lo + rbox.lo), rcbox.hi = min4(cbox.hi, rbox.hi + rbox.hi);
    const auto [id, tp] = out_.take(at, depth);
    BvhNode& t = *tp;
    set_boxes(t, lbox, rbox);
    const size_t pm = pb + nl;
    auto left = [&] { t.child[0] = node(cb, mid, side ^ 1, pb, pm, lbox, lcbox, depth + 1, at + 1); };
    auto right = [&] { t.child[1] = node(mid, ce, side ^ 1, pm, pe, rbox, rcbox, depth + 1, at + uint32_t(nl)); };
    if (n >= kParallelSubtree && parallel_) {
      tbb::parallel_invoke(left, right);
    } else {
      left();
      right();
    }
    return id;
  }
};

// The clustered build (ClusterBuilder) over refs[0, n) (bounds rb; sorted
// and spare: room for n references each). Its scratch arrays reuse memory
// the build has already or will have touched: the keys lie in out.nodes
// (room for n - 1 ≥ 2n/8 nodes; written only once the keys are no longer
// needed), the clusters in refs once those are copied to `sorted` (their
// partitions' second buffer after them, or in spare). Every pass runs in
// parallel on more than one thread, in blocks that do not depend on the
// thread count.
void build_clustered(PrimRef* refs, PrimRef* sorted, PrimRef* spare, size_t n, const RootBounds& rb,
                     Builder::Out& out, const BvhBuildOptions& opt) {
  static_assert(sizeof(BvhNode) >= 2 * 2 * sizeof(uint64_t));
  const bool parallel = out.parallel && n >= 2 * kSortBlock;
  const size_t block = parallel ? sort_block(n) : n, blocks = (n + block - 1) / block;

  // Keys: the Morton codes of the centroids on the 2^kMortonBits grid over
  // the cube around the centroid bounds (binned as the SAH bins them, into
  // 1024 bins per axis), over the references' indices. Sorted by three
  // radix passes, one per kMortonBits bits (on one thread, all three
  // histograms are counted here; in parallel, each pass counts its blocks
  // first).
  // (Each reuse of out.nodes' storage starts its objects' lifetimes, here
  // and below: for these trivial types, no code.)
  uint64_t* keys = reinterpret_cast<uint64_t*>(out.nodes);
  std::uninitialized_default_construct_n(keys, 2 * n);
  uint64_t* tmp = keys + n;
  std::vector<uint32_t> hist(3 * blocks * kDigits, 0);
  const Box grid_box = cube(rb.cbox);
  const Binner grid(grid_box, int(kDigits));
  for_blocks(n, block, parallel, [&](size_t b, size_t e, size_t k) {
    uint32_t* h = hist.data() + k * kDigits;  // pass 0
    uint32_t* h1 = hist.data() + blocks * kDigits;
    for (size_t i = b; i < e; ++i) {
      const uint32_t code = morton(grid.bin(centroid2(refs[i])));
      keys[i] = uint64_t(code) << 32 | i;
      ++h[code & (kDigits - 1)];
      if (!parallel) {
        ++h1[(code >> kMortonBits) & (kDigits - 1)];
        ++h1[kDigits + (code >> 2 * kMortonBits)];
      }
    }
  });
  for (int pass = 0; pass < 3; ++pass) {
    uint32_t* h = hist.data() + pass * blocks * kDigits;
    const int shift = 32 + pass * kMortonBits;
    if (parallel && pass > 0)
      for_blocks(n, block, true, [&](size_t b, size_t e, size_t k) {
        for (size_t i = b; i < e; ++i) ++h[k * kDigits + ((keys[i] >> shift) & (kDigits - 1))];
      });
    // All keys with one digit: nothing to sort.
    const size_t d0 = (keys[0] >> shift) & (kDigits - 1);
    size_t same = 0;
    for (size_t k = 0; k < blocks; ++k) same += h[k * kDigits + d0];
    if (same == n) continue;
    radix_pass(keys, tmp, n, block, shift, h, parallel);
    std::swap(keys, tmp);
  }

  // The primitives in their order; the clusters.
  for_blocks(n, block, parallel, [&](size_t b, size_t e, size_t) {
    for (size_t i = b; i < e; ++i) sorted[i] = refs[uint32_t(keys[i])];  // independent loads: they overlap
  });
  // The depths of make_clusters and the cuts (as many as primitives at
  // most, and an end) after the keys in out.nodes: 16n + (n + 8) + 8(n + 1)
  // bytes, within the nodes' 64(n - 1) for n > kSweepMax, dead before any
  // node is written.
  static_assert(sizeof(Cut) == 8 && alignof(Cut) <= 8);
  uint8_t* depths = reinterpret_cast<uint8_t*>(std::min(keys, tmp) + 2 * n);
  Cut* cuts = reinterpret_cast<Cut*>(depths + ((n + 1 + 7) & ~size_t(7)));
  std::uninitialized_default_construct_n(depths, n + 1);
  std::uninitialized_default_construct_n(cuts, n + 1);
  const size_t ncuts = make_clusters(keys, sorted, n, depths, cuts, parallel);
  cuts[ncuts] = {uint32_t(n), 0};

  // The clusters' references: cluster_refs(k0, k1, emit) calls emit(s, e,
  // box) for the clusters of cuts[k0, k1), in order, after the rules on
  // large primitives (leaving primitives of sorted[s, e) in their order).
  float cell[33];  // the half area of a cell of depth q (x splits first)
  for (int q = 32 - 3 * kMortonBits; q <= 32; ++q) {
    const int bits = q - (32 - 3 * kMortonBits);
    f4 e = (grid_box.hi - grid_box.lo) * splat(0.5f);  // centroid2: twice the centres
    e = f4{std::ldexp(e[0], -(bits + 2) / 3), std::ldexp(e[1], -(bits + 1) / 3), std::ldexp(e[2], -bits / 3), 0.f};
    cell[q] = e[0] * e[1] + e[1] * e[2] + e[2] * e[0];
  }
  auto cluster_refs = [&](size_t k0, size_t k1, auto&& emit) {
    for (size_t k = k0; k < k1; ++k) {
      const uint32_t s = cuts[k].start, m = cuts[k + 1].start - s;
      const PrimRef* p = sorted + s;
      Box all;
      for (uint32_t j = 0; j < m; ++j) all.grow(xyz(p[j].lo), p[j].hi);
      if (m == 1) {
        emit(s, s + 1, all);
        continue;
      }
      if (all.half_area() > kDissolve * cell[std::min<int>(cuts[k].depth, 32)]) {
        // Far larger than its cell (long primitives crossing each other):
        // only binning them one by one separates them.
        for (uint32_t j = 0; j < m; ++j) {
          Box one;
          one.grow(xyz(p[j].lo), p[j].hi);
          emit(s + j, s + j + 1, one);
        }
        continue;
      }
      // A primitive more than kLargeFactor larger than the others together
      // leaves them. The others' box: the union of the boxes before it (lo,
      // hi) and after it (slo, shi).
      f4 slo[kClusterMax + 1], shi[kClusterMax + 1];
      slo[m] = splat(kInf), shi[m] = splat(-kInf);
      for (uint32_t j = m; j-- > 0;) slo[j] = min4(slo[j + 1], xyz(p[j].lo)), shi[j] = max4(shi[j + 1], p[j].hi);
      f4 lo = splat(kInf), hi = splat(-kInf);
      Box b;
      uint32_t large = 0;  // bit j: primitive j leaves
      for (uint32_t j = 0; j < m; ++j) {
        const f4 plo = xyz(p[j].lo), phi = p[j].hi;
        if (half_area(plo, phi) > kLargeFactor * half_area(min4(lo, slo[j + 1]), max4(hi, shi[j + 1])))
          large |= 1u << j;
        else
          b.grow(plo, phi);
        lo = min4(lo, plo), hi = max4(hi, phi);
      }
      if (!large) {
        emit(s, s + m, b);
        continue;
      }
      // The others first, in order, then the large ones, one cluster each.
      PrimRef copy[kClusterMax];
      std::copy(p, p + m, copy);
      uint32_t w = s;
      for (uint32_t j = 0; j < m; ++j)
        if (!(large >> j & 1)) sorted[w++] = copy[j];
      if (w > s) emit(s, w, b);
      for (uint32_t j = 0; j < m; ++j) {
        if (!(large >> j & 1)) continue;
        sorted[w] = copy[j];
        Box one;
        one.grow(xyz(copy[j].lo), copy[j].hi);
        emit(w, w + 1, one);
        ++w;
      }
    }
  };
  auto make_ref = [](uint32_t s, uint32_t e, const Box& b) {
    PrimRef c;
    c.lo = (f4)(((i4)b.lo & i4{-1, -1, -1, 0}) | i4{0, 0, 0, int32_t(s)});
    c.hi = (f4)(((i4)b.hi & i4{-1, -1, -1, 0}) | i4{0, 0, 0, kCountBase + int32_t(e - s)});
    return c;
  };
  PrimRef* c0 = refs;  // at most n clusters
  Box box, cbox;
  size_t count = 0;
  if (!parallel) {
    cluster_refs(0, ncuts, [&](uint32_t s, uint32_t e, const Box& b) {
      c0[count++] = make_ref(s, e, b);
      box.grow(b);
      cbox.grow(xyz(b.lo) + xyz(b.hi));
    });
  } else {
    // Blocks of cuts, each writing its clusters from c0[its first
    // primitive's position] on (no more clusters than primitives), then
    // moved down together, in order.
    constexpr size_t kCutBlock = 4096;
    const size_t nblocks = (ncuts + kCutBlock - 1) / kCutBlock;
    std::vector<size_t> made(nblocks);
    std::vector<RootBounds> bounds(nblocks);
    for_blocks(ncuts, kCutBlock, true, [&](size_t k0, size_t k1, size_t k) {
      PrimRef* to = c0 + cuts[k0].start;
      size_t m = 0;
      cluster_refs(k0, k1, [&](uint32_t s, uint32_t e, const Box& b) {
        to[m++] = make_ref(s, e, b);
        bounds[k].box.grow(b);
        bounds[k].cbox.grow(xyz(b.lo) + xyz(b.hi));
      });
      made[k] = m;
    });
    for (size_t k = 0; k < nblocks; ++k) {
      std::memmove(static_cast<void*>(c0 + count), c0 + cuts[k * kCutBlock].start, made[k] * sizeof(PrimRef));
      count += made[k];
      box.grow(bounds[k].box);
      cbox.grow(bounds[k].cbox);
    }
  }

  // Their second buffer after them, if it fits (it does on the scenes
  // measured: a cluster holds 4 to 9 primitives on average), else in spare.
  PrimRef* c1 = 2 * count <= n ? refs + count : spare;
  std::uninitialized_default_construct_n(out.nodes, n - 1);  // nodes again, over the keys and cuts
  ClusterBuilder(c0, c1, sorted, out, opt).run(count, n, box, cbox);
}

// Orders the nodes of a parallel build: the nodes stored in slots[0,
// total) (each with its number in pad[0]; kHole: an unused slot), node k
// (bit k set in mask) to place rank(k), the number of used numbers before
// it, its inner children renumbered to match, its pad cleared: the serial
// build's numbering. In parallel, in two passes through `temp` (room for
// the nodes; memory the build has touched already, so no page faults):
// blocks of slots to their final places in temp, then temp back to the
// front of `slots`.
void compact(BvhNode* slots, size_t total, const uint64_t* mask, size_t words, BvhNode* temp) {
  std::vector<uint32_t> before(words + 1);  // used numbers in the words before
  before[0] = 0;
  for (size_t w = 0; w < words; ++w) before[w + 1] = before[w] + uint32_t(std::popcount(mask[w]));
  auto rank = [&](uint32_t k) {
    return before[k / 64] + uint32_t(std::popcount(mask[k / 64] & ((uint64_t(1) << (k % 64)) - 1)));
  };
  const uint32_t count = before[words];
  std::uninitialized_default_construct_n(temp, count);
  for_blocks(total, 4096, true, [&](size_t b, size_t e, size_t) {
    for (size_t i = b; i < e; ++i) {
      BvhNode node = slots[i];
      const uint32_t k = node.pad[0];
      if (k == kHole) continue;
      for (int c = 0; c < 2; ++c)
        if (!bvh_is_leaf(node.child[c])) node.child[c] = rank(node.child[c]);
      node.pad[0] = 0;
      temp[rank(k)] = node;
    }
  });
  for_blocks(count, 4096, true, [&](size_t b, size_t e, size_t) { std::copy(temp + b, temp + e, slots + b); });
}

}  // namespace

namespace {

// Instance k's world box: its object's box mapped corner by corner, grown
// by a few ulps of its magnitude so that rounding in the map never leaves a
// placed vertex outside. An object without triangles: the point its origin
// maps to (traversal never enters it).
void instance_box(const InstancesView& v, uint32_t k, Vec3& lo, Vec3& hi) {
  const Instance& in = v.list[k];
  const SceneObject& o = v.objects[in.object];
  if (o.num_triangles == 0) {
    lo = hi = in.to_world.point({});
    return;
  }
  lo = Vec3{kInfinity, kInfinity, kInfinity};
  hi = -lo;
  for (int c = 0; c < 8; ++c) {
    const Vec3 p = in.to_world.point({c & 1 ? o.hi.x : o.lo.x, c & 2 ? o.hi.y : o.lo.y, c & 4 ? o.hi.z : o.lo.z});
    lo = vmin(lo, p);
    hi = vmax(hi, p);
  }
  const float pad = max(max_abs(lo), max_abs(hi)) * 0x1p-20f;
  lo = lo - Vec3{pad, pad, pad};
  hi = hi + Vec3{pad, pad, pad};
}

// Each object's own tree, over its triangles alone, appended to
// bvh.object_nodes / object_prims.
void build_object_trees(const SceneView& scene, const BvhBuildOptions& options, Bvh& bvh, BvhScratch& work) {
  const InstancesView& v = scene.instances;
  Bvh one;
  for (uint32_t k = 0; k < v.num_objects; ++k) {
    const SceneObject& o = v.objects[k];
    SceneView sub;
    sub.positions = scene.positions;
    sub.indices = scene.indices + 3 * size_t(o.first_triangle);
    sub.num_triangles = o.num_triangles;
    build_bvh(sub, options, one, work);
    BvhObjectTree t;
    t.first_node = uint32_t(bvh.object_nodes.size());
    t.num_nodes = uint32_t(one.nodes.size());
    t.first_prim = uint32_t(bvh.object_prims.size());
    t.first_triangle = o.first_triangle;
    bvh.objects.push_back(t);
    bvh.object_nodes.insert(bvh.object_nodes.end(), one.nodes.begin(), one.nodes.end());
    bvh.object_prims.insert(bvh.object_prims.end(), one.prims.begin(), one.prims.end());
  }
}

}  // namespace

BvhScratch::~BvhScratch() { build_deallocate(p_, bytes_, 64); }

void* BvhScratch::get(size_t bytes) {
  if (bytes > bytes_ || !p_) {
    build_deallocate(p_, bytes_, 64);
    p_ = nullptr;
    bytes_ = 0;
    p_ = build_allocate(bytes, 64);  // PrimRefs: 32-byte aligned
    bytes_ = bytes;
  }
  return p_;
}

Bvh build_bvh(const SceneView& scene, const BvhBuildOptions& options) {
  Bvh bvh;
  BvhScratch scratch;
  build_bvh(scene, options, bvh, scratch);
  // The nodes' storage past the tree (room for n - 1 nodes, about twice
  // what a tree takes, partly touched by the clusters' keys and cuts) back
  // to the kernel: the vector keeps its capacity, not the memory. (A
  // rebuild keeps it, to write there again.) Only from 1 MiB: a small
  // vector lives in malloc's heap, whose next allocations there would fault
  // the pages in again (a 36-triangle scene's build took 5 -> 17 µs, and
  // the next small rebuild 5 -> 35 µs, once a parallel build's room for
  // the threads' chunks made its tail span pages).
#if defined(MADV_DONTNEED)
  const uintptr_t page = uintptr_t(sysconf(_SC_PAGESIZE));
  const uintptr_t b = (reinterpret_cast<uintptr_t>(bvh.nodes.data() + bvh.nodes.size()) + page - 1) & ~(page - 1);
  const uintptr_t e = reinterpret_cast<uintptr_t>(bvh.nodes.data() + bvh.nodes.capacity()) & ~(page - 1);
  if (page > 0 && e > b && e - b >= (uintptr_t(1) << 20)) madvise(reinterpret_cast<void*>(b), e - b, MADV_DONTNEED);
#endif
  return bvh;
}

void build_bvh(const SceneView& scene, const BvhBuildOptions& options, Bvh& bvh, BvhScratch& work) {
  auto t0 = std::chrono::steady_clock::now();
  size_t nt = scene.num_triangles, ns = scene.num_spheres, ni = scene.instances.count, n = nt + ns + ni;
  bvh.nodes.clear();
  bvh.prims.clear();
  bvh.object_nodes.clear();
  bvh.object_prims.clear();
  bvh.objects.clear();
  bvh.bounds_min = bvh.bounds_max = Vec3{};
  bvh.num_triangles = bvh.num_spheres = 0;
  bvh.num_leaves = bvh.max_depth = 0;
  bvh.build_seconds = 0;
  if (n >= kBvhMaxPrims) throw std::invalid_argument("build_bvh: too many primitives for the BVH's 27-bit leaf offsets");
  if (n == 0) return;
  if (ni > 0) build_object_trees(scene, options, bvh, work);
  bvh.num_triangles = scene.num_triangles;
  bvh.num_spheres = scene.num_spheres;

  auto build = [&] {
    // PrimRefs and the root's bounds in one pass (refs; twice as much scratch
    // space after them).
    PrimRef* rp = static_cast<PrimRef*>(work.get(3 * n * sizeof(PrimRef)));
    PrimRef* scratch = rp + n;
    PrimRef* spare = rp + 2 * n;  // touched only if the clusters need it
    auto make_refs = [&](size_t b, size_t e, RootBounds acc) {
      // Triangles (the first nt references), four lanes at a time.
      auto load = [](const Vec3& v) { return f4{v.x, v.y, v.z, 0.f}; };
      size_t i = b;
      for (; i < std::min(e, nt); ++i) {
        const uint32_t* ix = scene.indices + 3 * i;
        f4 a = load(scene.positions[ix[0]]), b2 = load(scene.positions[ix[1]]), c = load(scene.positions[ix[2]]);
        // + 0: -0 becomes +0, so that no min or max has to choose between
        // the two zeros (its pick depends on the order, which in the
        // parallel binning depends on the thread count).
        f4 lo = min4(a, min4(b2, c)) + splat(0.f), hi = max4(a, max4(b2, c)) + splat(0.f);
        rp[i].lo = (f4)((i4)lo | i4{0, 0, 0, int32_t(i)});
        rp[i].hi = hi;
        acc.box.grow(lo, hi);
        acc.cbox.grow(lo + hi);
      }
      for (; i < std::min(e, nt + ns); ++i) {
        const Sphere& s = scene.spheres[i - nt];
        // A few ulps of slack for intersect_sphere's rounding near tangents.
        float m = max(fabsf(s.center.x), max(fabsf(s.center.y), fabsf(s.center.z))) + fabsf(s.radius);
        float r = fabsf(s.radius) + m * 0x1p-20f;
        // Clamped to the finite range: a huge sphere's box would otherwise
        // reach ±inf on both sides, its centroid NaN, and NaN makes the
        // min/max reductions depend on how the work is split (the tree on
        // the thread count). Nothing beyond FLT_MAX can be hit anyway.
        const float big = 3.40282347e38f;
        Vec3 lo = vmax(s.center - Vec3{r, r, r}, Vec3{-big, -big, -big});
        Vec3 hi = vmin(s.center + Vec3{r, r, r}, Vec3{big, big, big});
        uint32_t id = uint32_t(i - nt) | kBvhSphereBit;
        PrimRef& p = rp[i];
        p.lo = f4{lo.x + 0.f, lo.y + 0.f, lo.z + 0.f, std::bit_cast<float>(id)};  // + 0: as above
        p.hi = f4{hi.x + 0.f, hi.y + 0.f, hi.z + 0.f, 0.f};
        acc.box.grow(xyz(p.lo), p.hi);
        acc.cbox.grow(centroid2(p));
      }
      for (; i < e; ++i) {
        const uint32_t k = uint32_t(i - nt - ns);
        Vec3 lo, hi;
        instance_box(scene.instances, k, lo, hi);
        PrimRef& p = rp[i];
        p.lo = f4{lo.x + 0.f, lo.y + 0.f, lo.z + 0.f, std::bit_cast<float>(k | kBvhInstanceBit)};  // + 0: as above
        p.hi = f4{hi.x + 0.f, hi.y + 0.f, hi.z + 0.f, 0.f};
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
    bvh.prims.resize(n);  // uninitialised (BuildAllocator)
    // Room for the n - 1 nodes a tree over n primitives may have, of which
    // only those written are touched: the nodes are made in bvh.nodes
    // itself, trimmed to their number after. On one thread they are made
    // depth first; on more, stored as made, ordered after (compact).
    const bool parallel = tbb::this_task_arena::max_concurrency() > 1;
    // (On more threads, room for the chunks' unused tails too: see Out.)
    const size_t threads = tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
    const size_t slots = std::max<size_t>(n - 1, 1) + (parallel ? size_t(Builder::Out::kChunk) * (threads + 1) : 0);
    bvh.nodes.resize(slots);
    std::vector<uint64_t> used(parallel ? (std::max<size_t>(n - 1, 1) + 63) / 64 : 0);
    Builder::Out out{bvh.nodes.data(), bvh.prims.data(), parallel, used.data(), slots};
    if (n <= size_t(kSweepMax) || options.median_split || options.full_sweep || !options.clusters)
      Builder(rp, scratch, n, 0, out, options).run(rb.box, rb.cbox);
    else
      build_clustered(rp, scratch, spare, n, rb, out, options);
    const uint32_t count = out.count();
    // (The PrimRefs' 96n bytes are free again: room for the n - 1 nodes.)
    if (parallel) {
      out.mark_holes();
      compact(bvh.nodes.data(), out.next.load(), used.data(), used.size(), reinterpret_cast<BvhNode*>(rp));
    }
    bvh.nodes.resize(count);
    bvh.num_leaves = count + (n > 1);  // one prim: a leaf and an empty one
    bvh.max_depth = out.max_depth();
  };
  // threads = 0: the current arena (a new arena would take every core).
  // Nothing half-built is left behind when the build throws.
  try {
    if (options.threads > 0)
      tbb::task_arena(options.threads).execute(build);
    else
      build();
  } catch (...) {
    bvh.nodes.clear();
    bvh.prims.clear();
    bvh.object_nodes.clear();
    bvh.object_prims.clear();
    bvh.objects.clear();
    bvh.num_triangles = bvh.num_spheres = 0;
    throw;
  }
  const BvhNode& root = bvh.nodes[0];
  Box rb = child_box(root, 0);
  rb.grow(child_box(root, 1));
  bvh.bounds_min = {rb.lo[0], rb.lo[1], rb.lo[2]};
  bvh.bounds_max = {rb.hi[0], rb.hi[1], rb.hi[2]};
  bvh.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

BvhTracer make_bvh_tracer(const Bvh& bvh, const SceneView& scene) {
  BvhTracer t;
  t.bvh = bvh.view();
  t.geometry.positions = scene.positions;
  t.geometry.indices = scene.indices;
  t.geometry.spheres = scene.spheres;
  t.geometry.opacity = scene.opacity();
  t.instancing = bvh.instancing(scene.instances);
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
