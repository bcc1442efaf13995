// Luz's own BVH: the node layout and the traversal, written once for the CPU
// and CUDA (DESIGN.md, "Traversal"). The builder is host-only, in
// bvh_build.h / bvh_build.cpp; this header is all a device kernel needs.
//
// Layout (Aila & Laine 2009, "Understanding the efficiency of ray traversal
// on GPUs"): a binary tree whose nodes store the boxes of BOTH children, so
// that one 64-byte node fetch (four 16-byte loads) tests two boxes. Leaves
// are not nodes: a child reference is either an inner node's index or a leaf,
// a contiguous range of `prims` (primitive references, reordered by the
// builder so every leaf is one range).
//
// A primitive reference is a tagged 32-bit id: bit 31 set = sphere, bit 30
// set = instance, neither = triangle; the other bits index Scene::spheres,
// the instances or the triangles.
//
// Instances (two levels): the scene's tree holds the world's triangles and
// spheres beside one reference per instance, boxed by its object's bounds
// mapped to world space; each object has its own tree over its triangles
// (BvhInstancing: all objects' trees back to back). Traversal that meets an
// instance leaves the rest of the leaf on the stack, maps the ray into
// object space (t is the same in both: the direction is mapped, not
// normalised) and descends the object's tree on the same stack; when the
// stack is back at the depth it had there, it returns to the world's ray.
//
// Traversal: a fixed-size local stack, near child first, no recursion, no
// virtual calls, no exceptions, no std containers. The ray-box test is the
// robust slab test (pbrt-v4 / Ize 2013: tfar scaled by 1 + 2γ₃ so that
// rounding never loses a box the ray touches); triangles use the watertight
// test of Woop, Benthin and Wald 2013 (as in pbrt-v4); spheres use
// luz::intersect_sphere, exactly as the Embree user geometry does.
//
// OptiX roles, for when this is mapped onto OptiX programs:
//   - intersect_triangle / intersect_sphere: the INTERSECTION program (the
//     built-in triangle intersector and a custom sphere program).
//   - bvh_closest_hit: traversal + CLOSEST HIT (the hit record kept at the end).
//   - bvh_any_hit: traversal + ANY HIT (terminate on first accepted hit), the
//     shadow-ray query (optixTrace with TERMINATE_ON_FIRST_HIT).
//   - OpacityView::keeps (material/opacity.h): the ANY HIT program of both
//     queries, which accepts or ignores each hit on a masked material.
#pragma once

#include "luz/geometry/shapes.h"
#include "luz/material/opacity.h"

namespace luz {

// ---------------------------------------------------------------- layout

inline constexpr uint32_t kBvhSphereBit = 0x80000000u;
inline constexpr uint32_t kBvhInstanceBit = 0x40000000u;
inline constexpr uint32_t kBvhLeafBit = 0x80000000u;
inline constexpr uint32_t kBvhLeafCountBits = 4;  // leaf sizes 0..15
inline constexpr uint32_t kBvhMaxLeafSize = (1u << kBvhLeafCountBits) - 1;
inline constexpr uint32_t kBvhMaxPrims = 1u << (31 - kBvhLeafCountBits);  // 2^27 leaf-range starts
inline constexpr int kBvhStackSize = 64;  // the builder keeps every tree shallower than this
// Two levels: the world's tree's stack, a leaf's rest, then an object's.
inline constexpr int kBvhTraversalStackSize = 2 * kBvhStackSize + 1;

// A child reference: an inner node (bit 31 clear: the index) or a leaf (bit 31
// set: first primitive in bits 4..30, count in bits 0..3).
LUZ_INLINE bool bvh_is_leaf(uint32_t c) { return (c & kBvhLeafBit) != 0; }
LUZ_INLINE uint32_t bvh_leaf_first(uint32_t c) { return (c & ~kBvhLeafBit) >> kBvhLeafCountBits; }
LUZ_INLINE uint32_t bvh_leaf_count(uint32_t c) { return c & kBvhMaxLeafSize; }
LUZ_INLINE uint32_t bvh_make_leaf(uint32_t first, uint32_t count) {
  return kBvhLeafBit | (first << kBvhLeafCountBits) | count;
}

// 64 bytes, as four float4 in Aila & Laine's order:
//   (c0.lo.x, c0.hi.x, c0.lo.y, c0.hi.y) (c1.lo.x, c1.hi.x, c1.lo.y, c1.hi.y)
//   (c0.lo.z, c0.hi.z, c1.lo.z, c1.hi.z) (child0, child1, -, -)
struct alignas(16) BvhNode {
  float c0_lx, c0_hx, c0_ly, c0_hy;
  float c1_lx, c1_hx, c1_ly, c1_hy;
  float c0_lz, c0_hz, c1_lz, c1_hz;
  uint32_t child[2];
  uint32_t pad[2];
};
static_assert(sizeof(BvhNode) == 64, "BvhNode is one 64-byte line");

// The built tree as plain pointers: valid on the host, or with every pointer
// replaced by a device copy of the same array.
struct BvhView {
  const BvhNode* nodes = nullptr;  // nodes[0] is the root
  uint32_t num_nodes = 0;          // 0: empty scene
  const uint32_t* prims = nullptr; // tagged primitive references, leaf order
  uint32_t num_prims = 0;
};

// ---------------------------------------------------------------- ray-box

// Ray data precomputed once per ray.
struct BvhRay {
  Vec3 o, d, inv_d;
};

LUZ_INLINE BvhRay bvh_make_ray(const Ray& r) {
  BvhRay br;
  br.o = r.o;
  br.d = r.d;
  // A zero (or denormal) direction component would give 0·∞ = NaN in the slab
  // test when the origin lies on a slab plane. A huge finite reciprocal gives
  // 0 there and ±(huge or ∞) elsewhere: the slab then holds for all t when
  // the origin is inside it and for none (in practice) when outside.
  constexpr float kHuge = 3.0e38f;
  for (int i = 0; i < 3; ++i) {
    float di = r.d[i];
    br.inv_d[i] = fabsf(di) > 1e-30f ? 1.f / di : copysignf(kHuge, di);
  }
  return br;
}

// 1 + 2γ₃ with γₙ = nε/(1 − nε), ε = 2⁻²⁴ (pbrt-v4, Bounds3::IntersectP; Ize
// 2013, "Robust BVH ray traversal"): scaling each slab's far t by it makes
// the test conservative under float rounding.
inline constexpr float kBvhTfarScale = 1.f + 2.f * (3.f * 0x1p-24f) / (1.f - 3.f * 0x1p-24f);

// Slab test of one box against (0, tmax]. Returns the entry distance through
// `tnear`. Written with min/max such that a NaN never makes a box pass.
LUZ_INLINE bool bvh_slab(const BvhRay& r, float lx, float hx, float ly, float hy, float lz, float hz, float tmax,
                         float& tnear) {
  float tx0 = (lx - r.o.x) * r.inv_d.x, tx1 = (hx - r.o.x) * r.inv_d.x;
  float ty0 = (ly - r.o.y) * r.inv_d.y, ty1 = (hy - r.o.y) * r.inv_d.y;
  float tz0 = (lz - r.o.z) * r.inv_d.z, tz1 = (hz - r.o.z) * r.inv_d.z;
  float tn = max(max(min(tx0, tx1), min(ty0, ty1)), max(min(tz0, tz1), 0.f));
  float tf = min(min(max(tx0, tx1), max(ty0, ty1)), min(max(tz0, tz1), tmax));
  tnear = tn;
  return tn <= tf * kBvhTfarScale;
}

// ---------------------------------------------------------------- primitives

// a·b − c·d with one rounding error at most of about 1.5 ulp (Kahan's
// algorithm, pbrt-v4's DifferenceOfProducts). Its sign is the exact sign.
LUZ_INLINE float bvh_difference_of_products(float a, float b, float c, float d) {
  float cd = c * d;
  float err = fmaf(-c, d, cd);
  float dop = fmaf(a, b, -cd);
  return dop + err;
}

struct TriangleHit {
  float t, b1, b2;  // b1, b2: barycentrics of p1 and p2 (Embree's u, v)
};

// INTERSECTION program (triangles). Watertight ray-triangle test (Woop,
// Benthin & Wald 2013, "Watertight ray/triangle intersection"), following
// pbrt-v4's IntersectTriangle: a ray on the shared edge of two triangles hits
// at least one of them. Accepts 0 < t < tmax as computed, like Embree with
// tnear = 0. pbrt-v4's further "t > δt" (t's error bound) is left out on
// purpose: it rejects genuine hits at small t of rays leaving a surface
// through the integrator's offsets (Wächter & Binder), which Embree reports;
// the only rays it would settle are those whose origin lies ON a triangle's
// plane (exact t = 0), where both tracers are at the mercy of rounding.
LUZ_INLINE bool intersect_triangle(Vec3 o, Vec3 d, Vec3 p0, Vec3 p1, Vec3 p2, float tmax, TriangleHit& out) {
  // Translate to the ray origin; permute so that z is the largest |d| axis.
  Vec3 a = p0 - o, b = p1 - o, c = p2 - o;
  float adx = fabsf(d.x), ady = fabsf(d.y), adz = fabsf(d.z);
  int kz = adx > ady ? (adx > adz ? 0 : 2) : (ady > adz ? 1 : 2);
  int kx = kz + 1 == 3 ? 0 : kz + 1;
  int ky = kx + 1 == 3 ? 0 : kx + 1;
  float dx = d[kx], dy = d[ky], dz = d[kz];
  float ax = a[kx], ay = a[ky], az = a[kz];
  float bx = b[kx], by = b[ky], bz = b[kz];
  float cx = c[kx], cy = c[ky], cz = c[kz];
  // Shear so the ray runs along +z.
  float sx = -dx / dz, sy = -dy / dz, sz = 1.f / dz;
  ax += sx * az;
  ay += sy * az;
  bx += sx * bz;
  by += sy * bz;
  cx += sx * cz;
  cy += sy * cz;
  // Edge functions (e0 is opposite p0, etc.).
  float e0 = bvh_difference_of_products(bx, cy, by, cx);
  float e1 = bvh_difference_of_products(cx, ay, cy, ax);
  float e2 = bvh_difference_of_products(ax, by, ay, bx);
  if (e0 == 0.f || e1 == 0.f || e2 == 0.f) {
    // Exactly on an edge in float: decide in double (exact products).
    e0 = float(double(bx) * double(cy) - double(by) * double(cx));
    e1 = float(double(cx) * double(ay) - double(cy) * double(ax));
    e2 = float(double(ax) * double(by) - double(ay) * double(bx));
  }
  if ((e0 < 0.f || e1 < 0.f || e2 < 0.f) && (e0 > 0.f || e1 > 0.f || e2 > 0.f)) return false;
  float det = e0 + e1 + e2;
  if (det == 0.f) return false;
  az *= sz;
  bz *= sz;
  cz *= sz;
  float t_scaled = e0 * az + e1 * bz + e2 * cz;
  if (det < 0.f && (t_scaled >= 0.f || t_scaled <= tmax * det)) return false;
  if (det > 0.f && (t_scaled <= 0.f || t_scaled >= tmax * det)) return false;
  float inv_det = 1.f / det;
  float t = t_scaled * inv_det;
  if (!(t > 0.f && t < tmax)) return false;  // rounding of the division
  out.t = t;
  out.b1 = e1 * inv_det;
  out.b2 = e2 * inv_det;
  return true;
}

// The geometry a traversal reads besides the tree (the SceneView's arrays).
struct BvhGeometry {
  const Vec3* positions = nullptr;
  const uint32_t* indices = nullptr;
  const Sphere* spheres = nullptr;
  OpacityView opacity;  // the alpha test (ANY HIT program of masked materials), or empty
};

// One object's tree inside BvhInstancing's arrays: its nodes and
// references (the object's triangles counted from first_triangle).
struct BvhObjectTree {
  uint32_t first_node = 0, num_nodes = 0;  // num_nodes 0: no triangles
  uint32_t first_prim = 0, first_triangle = 0;
};

// The instances' side of a two-level tree (count 0: none).
struct BvhInstancing {
  const BvhNode* nodes = nullptr;   // every object's tree, back to back
  const uint32_t* prims = nullptr;  // their references
  const BvhObjectTree* objects = nullptr;
  const Instance* instances = nullptr;  // the scene's: to_object, object
  uint32_t count = 0;
};

// INTERSECTION program dispatch: one tagged primitive against the ray
// (triangle refs counted from tri_base: an object's first triangle).
LUZ_INLINE bool bvh_intersect_prim(const BvhGeometry& g, const BvhRay& r, uint32_t ref, float tmax, Hit& hit,
                                   uint32_t tri_base = 0) {
  if (ref & kBvhSphereBit) {
    uint32_t k = ref & ~kBvhSphereBit;
    const Sphere& s = g.spheres[k];
    float t = intersect_sphere(s.center, s.radius, r.o, r.d, tmax);
    if (!(t > 0.f)) return false;
    hit.t = t;
    hit.prim = k;
    hit.kind = PrimKind::Sphere;
    hit.u = hit.v = 0.f;
    return true;
  }
  const uint32_t* ix = g.indices + 3 * size_t(ref + tri_base);
  TriangleHit th;
  if (!intersect_triangle(r.o, r.d, g.positions[ix[0]], g.positions[ix[1]], g.positions[ix[2]], tmax, th))
    return false;
  hit.t = th.t;
  hit.prim = ref + tri_base;
  hit.kind = PrimKind::Triangle;
  hit.u = th.b1;
  hit.v = th.b2;
  return true;
}

// ---------------------------------------------------------------- traversal

// Stack-based traversal shared by both queries. AnyHit: return at the first
// primitive hit (ANY HIT terminating the ray); otherwise shrink tmax on every
// hit and keep the closest (CLOSEST HIT). Instances: see the top of the file.
// kFull false: for a tree without instances or masked materials
// (BvhTracer::plain), the loop without their code: in CUDA the second
// level's state and the alpha test's texture lookup would hold registers
// all through the loop (sm_90: 46 registers for the ray-tracing kernel
// against 85).
template <bool AnyHit, bool kFull = true>
LUZ_INLINE bool bvh_traverse(const BvhView& bvh, const BvhGeometry& g, const BvhInstancing& inst, const Ray& ray,
                             Hit& hit) {
  if (bvh.num_nodes == 0) return false;
  const BvhRay world = bvh_make_ray(ray);
  BvhRay r = world;
  // The tree being traversed: the world's, or an instance's object's.
  const BvhNode* nodes = bvh.nodes;
  const uint32_t* prims = bvh.prims;
  uint32_t tri_base = 0, in_instance = kNoInstance;
  int instance_sp = -1;  // the stack depth at which the instance was entered
  float tmax = ray.tmax;
  bool found = false;
  uint32_t stack[kFull ? kBvhTraversalStackSize : kBvhStackSize];
  int sp = 0;
  uint32_t cur = 0;  // the root is an inner node
  for (;;) {
    if (!bvh_is_leaf(cur)) {
      float t0, t1;
#if defined(__CUDA_ARCH__)
      // The 64-byte node as four 16-byte loads through the read-only cache
      // (Aila & Laine's fetch), in the layout's order.
      const float4* q = reinterpret_cast<const float4*>(nodes + cur);
      const float4 xy0 = __ldg(q), xy1 = __ldg(q + 1), z01 = __ldg(q + 2);
      const uint2 ch = __ldg(reinterpret_cast<const uint2*>(q + 3));
      bool h0 = bvh_slab(r, xy0.x, xy0.y, xy0.z, xy0.w, z01.x, z01.y, tmax, t0);
      bool h1 = bvh_slab(r, xy1.x, xy1.y, xy1.z, xy1.w, z01.z, z01.w, tmax, t1);
      const uint32_t child0 = ch.x, child1 = ch.y;
#else
      const BvhNode& n = nodes[cur];
      bool h0 = bvh_slab(r, n.c0_lx, n.c0_hx, n.c0_ly, n.c0_hy, n.c0_lz, n.c0_hz, tmax, t0);
      bool h1 = bvh_slab(r, n.c1_lx, n.c1_hx, n.c1_ly, n.c1_hy, n.c1_lz, n.c1_hz, tmax, t1);
      const uint32_t child0 = n.child[0], child1 = n.child[1];
#endif
      if (h0 && h1) {
        // Near child first; the far one waits on the stack.
        uint32_t near_c = child0, far_c = child1;
        if (t1 < t0) {
          near_c = child1;
          far_c = child0;
        }
        stack[sp++] = far_c;
        cur = near_c;
        continue;
      }
      if (h0 || h1) {
        cur = h0 ? child0 : child1;
        continue;
      }
    } else {
      uint32_t first = bvh_leaf_first(cur), count = bvh_leaf_count(cur);
      bool entered = false;
      for (uint32_t i = 0; i < count; ++i) {
        const uint32_t ref = prims[first + i];
        if (kFull && (ref & (kBvhSphereBit | kBvhInstanceBit)) == kBvhInstanceBit) {
          const uint32_t k = ref & ~kBvhInstanceBit;
          const Instance& in = inst.instances[k];
          const BvhObjectTree& o = inst.objects[in.object];
          if (o.num_nodes == 0) continue;
          // Into the object: the rest of this leaf waits on the stack.
          if (i + 1 < count) stack[sp++] = bvh_make_leaf(first + i + 1, count - i - 1);
          Ray local;
          local.o = in.to_object.point(ray.o);
          local.d = in.to_object.vector(ray.d);
          r = bvh_make_ray(local);
          nodes = inst.nodes + o.first_node;
          prims = inst.prims + o.first_prim;
          tri_base = o.first_triangle;
          in_instance = k;
          instance_sp = sp;
          cur = 0;
          entered = true;
          break;
        }
        Hit h;
        if (bvh_intersect_prim(g, r, ref, tmax, h, tri_base) &&
            (!kFull || !g.opacity.materials || g.opacity.keeps(r.o, r.d, h))) {
          h.inst = in_instance;
          hit = h;
          if (AnyHit) return true;
          tmax = h.t;
          found = true;
        }
      }
      if (entered) continue;
    }
    if (kFull && sp == instance_sp) {  // the object is done: back to the world's tree and ray
      r = world;
      nodes = bvh.nodes;
      prims = bvh.prims;
      tri_base = 0;
      in_instance = kNoInstance;
      instance_sp = -1;
    }
    if (sp == 0) break;
    cur = stack[--sp];
  }
  return found;
}

// CLOSEST HIT: the nearest primitive in (0, ray.tmax).
LUZ_INLINE bool bvh_closest_hit(const BvhView& bvh, const BvhGeometry& g, const BvhInstancing& inst, const Ray& ray,
                                Hit& hit) {
  return bvh_traverse<false>(bvh, g, inst, ray, hit);
}

// ANY HIT: is anything in (0, ray.tmax)? Stops at the first hit.
LUZ_INLINE bool bvh_any_hit(const BvhView& bvh, const BvhGeometry& g, const BvhInstancing& inst, const Ray& ray) {
  Hit h;
  return bvh_traverse<true>(bvh, g, inst, ray, h);
}

// The Tracer (integrator/path.h) over Luz's BVH: path_li<BvhTracer> runs on
// the CPU and, with device copies of the arrays, in CUDA.
struct BvhTracer {
  BvhView bvh;
  BvhGeometry geometry;
  BvhInstancing instancing;

  LUZ_INLINE bool intersect(const Ray& ray, Hit& hit) const {
    return bvh_closest_hit(bvh, geometry, instancing, ray, hit);
  }
  LUZ_INLINE bool occluded(const Ray& ray) const { return bvh_any_hit(bvh, geometry, instancing, ray); }
  // Neither instances nor masked materials: BvhQueries<false> answers alike.
  LUZ_INLINE bool plain() const { return instancing.count == 0 && !geometry.opacity.materials; }
};

// A BvhTracer's queries in bvh_traverse's variant kFull (false: only for a
// plain() tracer), for the kernels that come in both.
template <bool kFull>
struct BvhQueries {
  const BvhTracer& t;
  LUZ_INLINE bool intersect(const Ray& ray, Hit& hit) const {
    return bvh_traverse<false, kFull>(t.bvh, t.geometry, t.instancing, ray, hit);
  }
  LUZ_INLINE bool occluded(const Ray& ray) const {
    Hit h;
    return bvh_traverse<true, kFull>(t.bvh, t.geometry, t.instancing, ray, h);
  }
};

}  // namespace luz
