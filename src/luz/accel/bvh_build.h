// Host-side construction of Luz's BVH (layout and traversal: bvh.h): binned
// SAH over the triangles and analytic spheres of a scene, parallel with TBB.
#pragma once

#include <cstddef>
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

struct Bvh {
  std::vector<BvhNode> nodes;   // depth-first order, root first
  std::vector<uint32_t> prims;  // tagged references (bit 31: sphere), leaf order
  Vec3 bounds_min{}, bounds_max{};
  uint32_t num_triangles = 0, num_spheres = 0;
  uint32_t num_leaves = 0, max_depth = 0;  // max_depth: inner levels (root = 1)
  double build_seconds = 0;

  BvhView view() const {
    BvhView v;
    v.nodes = nodes.data();
    v.num_nodes = uint32_t(nodes.size());
    v.prims = prims.data();
    v.num_prims = uint32_t(prims.size());
    return v;
  }
  // Bytes of the acceleration structure proper (nodes + references).
  size_t bytes() const { return nodes.size() * sizeof(BvhNode) + prims.size() * sizeof(uint32_t); }
};

// Builds over scene.positions/indices/num_triangles and spheres/num_spheres.
// Throws std::invalid_argument on more than kBvhMaxPrims primitives.
Bvh build_bvh(const SceneView& scene, const BvhBuildOptions& options = {});

// The tracer over `bvh` and the geometry arrays of `scene` (host pointers).
BvhTracer make_bvh_tracer(const Bvh& bvh, const SceneView& scene);

// SAH cost of the tree, normalised by the root's surface area:
//   Σ_inner A(n)/A(root)·C_trav + Σ_leaves A(l)/A(root)·|l|·C_isect.
double bvh_sah_cost(const Bvh& bvh, float traversal_cost = 1.f, float intersection_cost = 1.f);

}  // namespace luz
