// The light BVH's host build (light_bvh.h).
#include "luz/light/light_bvh.h"

#include <algorithm>
#include <cmath>

namespace luz {

namespace {

constexpr int kBuckets = 12;
// Below this depth the SAH splits; deeper, halves by count, so no leaf is
// deeper than kSahDepth + 32 for up to 2^32 lights, nor its trail longer than
// kLightTrailLevels (one wide level per three binary ones).
constexpr int kSahDepth = kLightBvhSlotBits * kLightTrailLevels - 32;
static_assert(kLightBvhSlotBits * kLightTrailLevels <= 62, "trails leave their top two bits to the flags");

struct BuildLight {
  LightBounds b;
  Vec3 centroid;
  uint32_t light;
};

// pbrt-v4's BVHLightSampler::EvaluateCost: power × the orientation measure
// M_Ω of the cone (θo, θe) (Conty Estevez and Kulla, eq. 1) × surface area,
// with the box's aspect along the split axis (Kr) against thin slabs.
double cost(const LightBounds& b, const LightBounds& all, int dim) {
  const double theta_o = std::acos(std::clamp(double(b.cos_theta_o), -1.0, 1.0));
  const double theta_e = std::acos(std::clamp(double(b.cos_theta_e), -1.0, 1.0));
  const double theta_w = std::min(theta_o + theta_e, M_PI);
  const double sin_o = std::sin(theta_o), cos_o = std::cos(theta_o);
  const double m_omega = 2 * M_PI * (1 - cos_o) +
                         M_PI / 2 * (2 * theta_w * sin_o - std::cos(theta_o - 2 * theta_w) - 2 * theta_o * sin_o + cos_o);
  const Vec3 diag = all.hi - all.lo, d = b.hi - b.lo;
  const double kr = double(std::max({diag.x, diag.y, diag.z})) / double(diag[dim]);
  const double area = 2.0 * (double(d.x) * d.y + double(d.y) * d.z + double(d.z) * d.x);
  return double(b.phi) * m_omega * kr * area;
}

// The binary tree before its collapse: a leaf holds one light.
struct BinaryNode {
  LightBounds b;
  uint32_t left = 0, right = 0;  // inner: the children
  uint32_t light = 0;            // leaf: the light
  bool leaf = false;
};

struct Builder {
  std::vector<BuildLight>& items;
  std::vector<BinaryNode> nodes;

  // Appends the subtree over items[start, end) and returns its root's index.
  uint32_t build(size_t start, size_t end, int depth) {
    const uint32_t node = uint32_t(nodes.size());
    nodes.emplace_back();
    if (end - start == 1) {
      nodes[node].b = items[start].b;
      nodes[node].light = items[start].light;
      nodes[node].leaf = true;
      return node;
    }
    LightBounds all = items[start].b;
    Vec3 clo = items[start].centroid, chi = clo;
    for (size_t k = start + 1; k < end; ++k) {
      all = bounds_union(all, items[k].b);
      clo = vmin(clo, items[k].centroid);
      chi = vmax(chi, items[k].centroid);
    }
    size_t mid = start;
    int best_dim = -1, best_bucket = -1;
    if (depth < kSahDepth) {
      double best = INFINITY;
      for (int dim = 0; dim < 3; ++dim) {
        if (!(chi[dim] > clo[dim])) continue;
        LightBounds bucket[kBuckets];
        int count[kBuckets] = {};
        auto bucket_of = [&](const BuildLight& l) {
          const int b = int(kBuckets * ((l.centroid[dim] - clo[dim]) / (chi[dim] - clo[dim])));
          return std::clamp(b, 0, kBuckets - 1);
        };
        for (size_t k = start; k < end; ++k) {
          const int b = bucket_of(items[k]);
          bucket[b] = count[b] ? bounds_union(bucket[b], items[k].b) : items[k].b;
          ++count[b];
        }
        for (int split = 0; split < kBuckets - 1; ++split) {
          LightBounds b0, b1;
          int n0 = 0, n1 = 0;
          for (int i = 0; i <= split; ++i)
            if (count[i]) b0 = n0 ? bounds_union(b0, bucket[i]) : bucket[i], n0 += count[i];
          for (int i = split + 1; i < kBuckets; ++i)
            if (count[i]) b1 = n1 ? bounds_union(b1, bucket[i]) : bucket[i], n1 += count[i];
          if (!n0 || !n1) continue;
          const double c = cost(b0, all, dim) + cost(b1, all, dim);
          if (c < best) {
            best = c;
            best_dim = dim;
            best_bucket = split;
          }
        }
      }
      if (best_dim >= 0) {
        const int dim = best_dim;
        auto it = std::partition(items.begin() + long(start), items.begin() + long(end), [&](const BuildLight& l) {
          const int b = int(kBuckets * ((l.centroid[dim] - clo[dim]) / (chi[dim] - clo[dim])));
          return std::clamp(b, 0, kBuckets - 1) <= best_bucket;
        });
        mid = size_t(it - items.begin());
      }
    }
    if (mid == start || mid == end) {
      // Halves by count along the centroids' widest axis.
      const Vec3 ext = chi - clo;
      const int dim = ext.x >= ext.y && ext.x >= ext.z ? 0 : ext.y >= ext.z ? 1 : 2;
      mid = (start + end) / 2;
      std::nth_element(items.begin() + long(start), items.begin() + long(mid), items.begin() + long(end),
                       [&](const BuildLight& a, const BuildLight& b) { return a.centroid[dim] < b.centroid[dim]; });
    }
    const uint32_t left = build(start, mid, depth + 1);
    const uint32_t right = build(mid, end, depth + 1);
    nodes[node].b = all;
    nodes[node].left = left;
    nodes[node].right = right;
    return node;
  }
};

// Writes binary node `from`'s bounds into slot i of a wide node: the box as
// its centre and a radius rounded up to hold its corners.
void set_slot(LightBvhNode& w, int i, const LightBounds& b) {
  const Vec3 c = (b.lo + b.hi) * 0.5f;
  double r2 = 0;
  for (int a = 0; a < 3; ++a) {
    const double e = std::max(double(c[a]) - b.lo[a], double(b.hi[a]) - c[a]);
    r2 += e * e;
  }
  w.cx[i] = c.x, w.cy[i] = c.y, w.cz[i] = c.z;
  w.radius[i] = std::nextafter(float(std::sqrt(r2)), INFINITY) * (r2 > 0 ? 1.f : 0.f);
  w.wx[i] = b.w.x, w.wy[i] = b.w.y, w.wz[i] = b.w.z;
  w.phi[i] = b.phi;
  w.cos_o[i] = b.cos_theta_o;
  w.sin_o[i] = float(std::sqrt(std::max(0.0, 1.0 - double(b.cos_theta_o) * b.cos_theta_o)));
  w.cos_e[i] = b.cos_theta_e;
}

// Collapses the binary tree three levels at a time: a wide node's children
// are the binary descendants three levels down (or the leaves above them),
// then, while slots are free, the inner ones of most power are opened
// further. So every wide level descends at least three binary ones and the
// trails fit kLightTrailLevels.
struct Collapser {
  const std::vector<BinaryNode>& bin;
  LightBvhData& out;

  uint32_t collapse(uint32_t root, uint64_t trail, int level) {
    uint32_t front[kLightBvhWidth];
    int n = 1;
    front[0] = root;
    auto open = [&](int i) {
      const BinaryNode& b = bin[front[i]];
      front[i] = b.left;
      front[n++] = b.right;
    };
    for (int round = 0; round < kLightBvhSlotBits; ++round)
      for (int i = 0, m = n; i < m; ++i)
        if (!bin[front[i]].leaf) open(i);
    while (n < kLightBvhWidth) {
      int best = -1;
      for (int i = 0; i < n; ++i)
        if (!bin[front[i]].leaf && (best < 0 || bin[front[i]].b.phi > bin[front[best]].b.phi)) best = i;
      if (best < 0) break;
      open(best);
    }
    const uint32_t node = uint32_t(out.nodes.size());
    out.nodes.emplace_back();
    for (int i = 0; i < n; ++i) {
      const BinaryNode& b = bin[front[i]];
      const uint64_t t = trail | (uint64_t(i) << (kLightBvhSlotBits * level));
      uint32_t child;
      if (b.leaf) {
        child = b.light | kLightBvhLeaf;
        out.trails[b.light] = t;
      } else {
        child = collapse(front[i], t, level + 1);
      }
      LightBvhNode& w = out.nodes[node];
      set_slot(w, i, b.b);
      w.child[i] = child | (b.b.two_sided ? kLightBvhTwoSided : 0u);
    }
    return node;
  }
};

}  // namespace

LightBvhData build_light_bvh(const Light* lights, const double* power, uint32_t n) {
  LightBvhData out;
  out.trails.assign(n, kTrailNone);
  std::vector<BuildLight> items;
  for (uint32_t k = 0; k < n; ++k) {
    if (!(power[k] > 0.0)) continue;
    const std::optional<LightBounds> b = bounds(lights[k]);
    if (!b) {
      const double w = irradiance_estimate(lights[k]);
      if (!(w > 0.0)) continue;
      out.trails[k] = kTrailInfinite | out.infinite.size();
      out.infinite.push_back(k);
      out.infinite_weight.push_back(float(w));
      out.infinite_total += float(w);
    } else if (b->phi > 0.f) {
      items.push_back({*b, (b->lo + b->hi) * 0.5f, k});
    }
  }
  if (!items.empty()) {
    Builder b{items, {}};
    b.nodes.reserve(2 * items.size() - 1);
    b.build(0, items.size(), 0);
    Collapser{b.nodes, out}.collapse(0, 0, 0);
  }
  return out;
}

}  // namespace luz
