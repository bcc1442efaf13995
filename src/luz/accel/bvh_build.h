// Host-side construction of Luz's BVH (layout and traversal: bvh.h): binned
// SAH over the triangles and analytic spheres of a scene, parallel with TBB.
#pragma once

#include <cstddef>
#include <memory>
#include <new>
#include <vector>

#include "luz/accel/bvh.h"
#include "luz/scene/scene_view.h"

namespace luz {

struct BvhBuildOptions {
  int bins = 32;                 // SAH bins per axis, 2..32 (all three axes are binned)
  uint32_t max_leaf_size = 8;    // leaves never hold more (≤ kBvhMaxLeafSize)
  float traversal_cost = 1.f;    // SAH: cost of one node visit (two boxes) ...
  float intersection_cost = 1.f; // ... relative to one primitive test
  bool median_split = false;     // baseline: object median on the widest centroid axis
  bool full_sweep = false;       // reference: exact SAH sweep over sorted centroids at every node (slow)
  bool clusters = true;          // above the small subtrees, bin clusters of primitives close in Morton
                                 // order, not single primitives (faster; false: the primitive builder)
  int threads = 0;               // 0: the current TBB arena
};

// The allocator of the build's output vectors: large ones on 2 MiB
// boundaries, advised onto transparent huge pages, and resize() leaves new
// elements uninitialised (default-initialised, as `new T` does), so that the
// builder writes the tree straight into a vector's storage, touching only
// what it writes, with no zeroing pass and no final copy.
template <class T>
struct BuildAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = BuildAllocator<U>;
  };
  BuildAllocator() = default;
  template <class U>
  BuildAllocator(const BuildAllocator<U>&) noexcept {}
  T* allocate(size_t n);
  void deallocate(T* p, size_t n) noexcept;
  template <class U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
template <class T, class U>
bool operator==(const BuildAllocator<T>&, const BuildAllocator<U>&) noexcept {
  return true;
}

// n bytes, 2 MiB-aligned and advised onto huge pages when at least 4 MiB
// (bvh_build.cpp).
void* build_allocate(size_t bytes, size_t align);
void build_deallocate(void* p, size_t bytes, size_t align) noexcept;
template <class T>
T* BuildAllocator<T>::allocate(size_t n) {
  if (n > size_t(-1) / sizeof(T)) throw std::bad_array_new_length();
  return static_cast<T*>(build_allocate(n * sizeof(T), alignof(T)));
}
template <class T>
void BuildAllocator<T>::deallocate(T* p, size_t n) noexcept {
  build_deallocate(p, n * sizeof(T), alignof(T));
}

struct Bvh {
  std::vector<BvhNode, BuildAllocator<BvhNode>> nodes;    // depth-first order, root first
  std::vector<uint32_t, BuildAllocator<uint32_t>> prims;  // tagged references (bit 31: sphere), leaf order
  Vec3 bounds_min{}, bounds_max{};
  uint32_t num_triangles = 0, num_spheres = 0;
  uint32_t num_leaves = 0, max_depth = 0;  // max_depth: inner levels (root = 1)
  double build_seconds = 0;
  // Instances (two levels, bvh.h): every object's tree, back to back; the
  // tree above (nodes, prims) then references each instance.
  std::vector<BvhNode, BuildAllocator<BvhNode>> object_nodes;
  std::vector<uint32_t, BuildAllocator<uint32_t>> object_prims;
  std::vector<BvhObjectTree> objects;

  BvhView view() const {
    BvhView v;
    v.nodes = nodes.data();
    v.num_nodes = uint32_t(nodes.size());
    v.prims = prims.data();
    v.num_prims = uint32_t(prims.size());
    return v;
  }
  // The instances' side, with the scene's instances (host pointers).
  BvhInstancing instancing(const InstancesView& scene) const {
    BvhInstancing v;
    if (objects.empty()) return v;
    v.nodes = object_nodes.data();
    v.prims = object_prims.data();
    v.objects = objects.data();
    v.instances = scene.list;
    v.count = scene.count;
    return v;
  }
  // Bytes of the acceleration structure proper (nodes + references).
  size_t bytes() const {
    return (nodes.size() + object_nodes.size()) * sizeof(BvhNode) +
           (prims.size() + object_prims.size()) * sizeof(uint32_t) + objects.size() * sizeof(BvhObjectTree);
  }
};

// Working memory a build keeps for the next one (96 bytes of address space
// per primitive, of which a build touches 64 to 96). Fresh memory is
// costly: the kernel maps and zeroes every page at its first touch, and on
// the VMs measured that took a third of a build's time on 263k triangles.
// Rebuilding (an animation; a benchmark) with the same BvhScratch and the
// same Bvh takes no fresh memory once they are large enough, but for a few
// small arrays.
class BvhScratch {
 public:
  BvhScratch() = default;
  BvhScratch(const BvhScratch&) = delete;
  BvhScratch& operator=(const BvhScratch&) = delete;
  ~BvhScratch();
  // At least `bytes` (2 MiB-aligned when large; contents undefined), kept
  // for the next call if large enough.
  void* get(size_t bytes);

 private:
  void* p_ = nullptr;
  size_t bytes_ = 0;
};

// Builds over scene.positions/indices/num_triangles and spheres/num_spheres,
// and over scene.instances: one tree per object, and the instances in the
// scene's tree.
// Throws std::invalid_argument on more than kBvhMaxPrims primitives.
Bvh build_bvh(const SceneView& scene, const BvhBuildOptions& options = {});

// The same tree, into `bvh` (whose vectors' storage is reused where large
// enough; every field is overwritten), with `scratch`'s memory. If the build
// throws, `bvh` is left empty.
void build_bvh(const SceneView& scene, const BvhBuildOptions& options, Bvh& bvh, BvhScratch& scratch);

// The tracer over `bvh` and the geometry arrays of `scene` (host pointers).
BvhTracer make_bvh_tracer(const Bvh& bvh, const SceneView& scene);

// SAH cost of the tree, normalised by the root's surface area:
//   Σ_inner A(n)/A(root)·C_trav + Σ_leaves A(l)/A(root)·|l|·C_isect.
double bvh_sah_cost(const Bvh& bvh, float traversal_cost = 1.f, float intersection_cost = 1.f);

}  // namespace luz
