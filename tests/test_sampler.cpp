// Sampler properties: values in [0,1), a pure function of (seed, pixel,
// index, dimension), and stratification where promised.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <vector>

#include "luz/sampling/sampler.h"

using namespace luz;

TEST(Sampler, PermuteIsAPermutation) {
  for (uint32_t n : {1u, 2u, 3u, 7u, 16u, 100u, 257u}) {
    std::set<uint32_t> seen;
    for (uint32_t i = 0; i < n; ++i) seen.insert(permute(i, n, 0x1234567u * n));
    EXPECT_EQ(seen.size(), n);
    EXPECT_LT(*seen.rbegin(), n);
  }
}

TEST(Sampler, PureFunctionOfCoordinates) {
  for (SamplerType t : {SamplerType::Independent, SamplerType::Stratified, SamplerType::Sobol}) {
    SamplerDesc d = make_sampler_desc(t, 16, 7);
    Sampler a, b;
    a.start(d, 3, 5, 9);
    a.next_1d();
    a.next_2d();
    float va = a.next_1d();
    b.start(d, 3, 5, 9);
    b.dim = 2;
    EXPECT_EQ(va, b.next_1d());
  }
}

// Each dimension of a pixel's spp samples falls one per stratum (1D), for the
// stratified and the Sobol sampler (spp a power of two).
TEST(Sampler, OneSamplePerStratum) {
  for (SamplerType t : {SamplerType::Stratified, SamplerType::Sobol}) {
    const uint32_t spp = 64;
    SamplerDesc d = make_sampler_desc(t, spp, 1);
    for (uint32_t dim = 0; dim < 6; ++dim) {
      std::vector<int> strata(spp, 0), sx(8, 0), sy(8, 0);
      for (uint32_t i = 0; i < spp; ++i) {
        Sampler s;
        s.start(d, 10, 20, i);
        s.dim = dim;
        float v = s.next_1d();
        ASSERT_GE(v, 0.f);
        ASSERT_LT(v, 1.f);
        strata[size_t(v * spp)]++;
        s.dim = dim;
        Vec2 w = s.next_2d();
        sx[size_t(w.x * 8)]++;
        sy[size_t(w.y * 8)]++;
      }
      for (int c : strata) EXPECT_EQ(c, 1) << "sampler " << int(t) << " dim " << dim;
      for (int k = 0; k < 8; ++k) {
        EXPECT_EQ(sx[k], 8);
        EXPECT_EQ(sy[k], 8);
      }
    }
  }
}

// The five-step Pascal transform equals the direction-number definition of
// Sobol dimension 1: v_0 = 2^31, v_k = v_{k-1} ^ (v_{k-1} >> 1).
TEST(Sampler, SobolDim1MatchesDirectionNumbers) {
  for (uint32_t i : {0u, 1u, 2u, 3u, 5u, 12345u, 0x80000000u, 0xdeadbeefu, 0xffffffffu}) {
    uint32_t r = 0, v = 1u << 31;
    for (uint32_t j = i; j; j >>= 1, v ^= v >> 1)
      if (j & 1u) r ^= v;
    EXPECT_EQ(sobol_dim1(i), r) << i;
  }
  // Owen scrambling with seed 0 of the bit-reversed form is still a bijection of [0, 2^k) blocks:
  for (uint32_t k = 1; k <= 8; ++k) {
    std::set<uint32_t> top;
    for (uint32_t i = 0; i < (1u << k); ++i) top.insert(owen_scramble(i, 0x9e3779b9u) >> k);
    EXPECT_EQ(top.size(), 1u) << "shuffled indices of the first 2^k samples must share one aligned block";
  }
}

// The 2D Sobol draw reverses its two outputs with one 64-bit reversal: the
// values must equal the per-dimension definitions.
TEST(Sampler, Sobol2DEqualsPerDimensionDefinition) {
  for (uint64_t v : {0x0123456789abcdefull, 0x8000000000000001ull, 0xffffffff00000000ull, 0x9e3779b97f4a7c15ull})
    EXPECT_EQ(reverse_bits64(v), uint64_t(reverse_bits32(uint32_t(v))) << 32 | reverse_bits32(uint32_t(v >> 32)));
  SamplerDesc d = make_sampler_desc(SamplerType::Sobol, 64, 11);
  for (uint32_t i = 0; i < 64; ++i)
    for (uint32_t dim = 0; dim < 8; ++dim) {
      Sampler s;
      s.start(d, 7, 3, i);
      s.dim = dim;
      Vec2 w = s.next_2d();
      uint64_t key = Sampler::dim_key(s.pixel_key, dim, 1);
      uint32_t lo = uint32_t(key), hi = uint32_t(key >> 32);
      uint32_t j = s.shuffle(lo);
      EXPECT_EQ(w.x, to_unit_float32(scrambled_sobol_dim0(j, hi)));
      EXPECT_EQ(w.y, to_unit_float32(scrambled_sobol_dim1(j, Sampler::third_seed(lo, hi))));
    }
}

// The bit work of the draws done in SSE lanes and 64-bit halves against the
// scalar definitions, on random words and the extremes.
TEST(Sampler, PackedBitOperationsEqualScalarOnes) {
  std::vector<uint32_t> words = {0u, 1u, 0x80000000u, 0xffffffffu, 0x000000ffu, 0xff000000u, 0x01234567u};
  for (uint32_t k = 0; k < 2000; ++k) words.push_back(lowbias32(k * 0x9e3779b9u + 17u));
  auto unit = [](uint32_t x) { return to_unit_float32(reverse_bits32(x)); };
  for (size_t k = 0; k + 3 < words.size(); ++k) {
    const uint32_t a = words[k], b = words[k + 1], c = words[k + 2], d = words[k + 3];
    const Vec2 p = reversed_unit_pair(a, b);
    EXPECT_EQ(p.x, unit(a));
    EXPECT_EQ(p.y, unit(b));
    Vec2 ab, cd;
    reversed_unit_quad(a, b, c, d, ab, cd);
    EXPECT_EQ(ab.x, unit(a));
    EXPECT_EQ(ab.y, unit(b));
    EXPECT_EQ(cd.x, unit(c));
    EXPECT_EQ(cd.y, unit(d));
    const uint64_t pp = sobol_pascal_lanes(uint64_t(b) << 32 | a);
    EXPECT_EQ(uint32_t(pp), sobol_pascal(a));
    EXPECT_EQ(uint32_t(pp >> 32), sobol_pascal(b));
  }
}

// The CPU renderer's shortcuts must not change a single number: draws from a
// pixel's cached seeds (inside and beyond the cached dimensions, every kind)
// and the paired 2D draw equal the plain draws, for every sampler.
TEST(Sampler, SeedCacheAndPairedDrawsGiveTheSameNumbers) {
  for (SamplerType t : {SamplerType::Independent, SamplerType::Stratified, SamplerType::Sobol})
    for (uint32_t px : {0u, 5u, 1023u}) {
      const SamplerDesc desc = make_sampler_desc(t, 16, 3 + px);
      const uint32_t cached = 13;
      std::vector<DimSeeds> storage(cached);
      for (uint32_t i = 0; i < 40; ++i) {
        Sampler plain, fast;
        plain.start(desc, px, 7, i);
        fast.start(desc, px, 7, 0);
        fast.cache_seeds(storage.data(), cached);
        fast.set_sample(i);
        EXPECT_EQ(fast.num_seeds, t == SamplerType::Sobol ? cached : 0u);
        for (uint32_t d = 0; d < 2 * cached; ++d) {
          const Vec2 a = plain.draw_2d(d), b = fast.draw_2d(d);
          EXPECT_EQ(a.x, b.x) << int(t) << " " << i << " " << d;
          EXPECT_EQ(a.y, b.y) << int(t) << " " << i << " " << d;
          EXPECT_EQ(plain.draw_1d(d, 0), fast.draw_1d(d, 0)) << int(t) << " " << i << " " << d;
          EXPECT_EQ(plain.aux_1d(d), fast.aux_1d(d)) << int(t) << " " << i << " " << d;
          for (const Sampler* s : {&plain, &fast}) {
            Vec2 p0, p1;
            s->draw_2d_pair(d, d + 5, p0, p1);
            const Vec2 q1 = plain.draw_2d(d + 5);
            EXPECT_EQ(p0.x, a.x);
            EXPECT_EQ(p0.y, a.y);
            EXPECT_EQ(p1.x, q1.x);
            EXPECT_EQ(p1.y, q1.y);
          }
        }
      }
    }
}

// aux_1d(d): a second 1D stream at dimension d, a pure function that leaves
// `dim` alone, independent of next_1d at d, and (Sobol, power-of-two spp) one
// value per stratum like the regular draws.
TEST(Sampler, AuxStreamIsSeparateAndStratified) {
  for (SamplerType t : {SamplerType::Independent, SamplerType::Stratified, SamplerType::Sobol}) {
    const uint32_t spp = 64;
    SamplerDesc d = make_sampler_desc(t, spp, 5);
    std::vector<int> strata(spp, 0);
    int equal = 0;
    for (uint32_t i = 0; i < spp; ++i) {
      Sampler s;
      s.start(d, 4, 9, i);
      s.dim = 3;
      float a = s.aux_1d(3);
      EXPECT_EQ(s.dim, 3u);
      EXPECT_EQ(a, s.aux_1d(3));
      ASSERT_GE(a, 0.f);
      ASSERT_LT(a, 1.f);
      equal += a == s.next_1d();
      strata[size_t(a * spp)]++;
    }
    EXPECT_LT(equal, 2) << "sampler " << int(t);
    if (t != SamplerType::Independent)
      for (int c : strata) EXPECT_EQ(c, 1) << "sampler " << int(t);
  }
}
