// The neighbour build's inner loop: of the particles in a contiguous range
// [b, e) of the cell-sorted store, write out those that make a pair with
// particle i: distance to x_i (taking the periodic image x_j + shift) below
// range(d_i, d_j) + skin, where every contact law's range is
// factor * (d_i + d_j) (contact/*.hpp, kRangeFactor), and not both of the
// excluded species. It also counts the pairs in contact now (distance below
// range), for the threads' block cut. About one candidate in seven is kept,
// so the loop keeps the test out of the branch predictor: with AVX-512,
// eight candidates at a time, the whole test in the vector lanes and a
// compress-store of the ones kept; with AVX2, four at a time, the kept ones'
// offsets from a table; otherwise one at a time, always writing the
// candidate and advancing the output only past a kept one. All give the
// same particles in the same order (tests/native/test_batch_kernels.cpp).
//
// Both forms compute r^2 as fma(dz, dz, fma(dy, dy, dx * dx)) and the
// cutoffs as the contact law does, so they agree to the bit; the pair loop
// tests contact itself, so a pair listed or not within a rounding of the
// list's cutoff (range + skin, outside contact) changes no force.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/space.hpp"

#if defined(__AVX512F__) && defined(__AVX512VL__) && defined(__BMI2__) && !defined(GRANULAR_NO_SIMD)
#include <immintrin.h>
#define GRANULAR_RANGE_SCAN_AVX512 1
#endif
// Every AVX-512 machine has AVX2: the tests check this form there too.
#if defined(__AVX2__) && defined(__FMA__) && !defined(GRANULAR_NO_SIMD)
#include <immintrin.h>
#define GRANULAR_RANGE_SCAN_AVX2 1
#endif

namespace granular {

// The pair test's parameters for row i.
struct PairScanRow {
  const double* xs;                 // x_i - shift, Dim doubles
  double di;                        // d_i
  double factor;                    // range(d_i, d_j) = factor * (d_i + d_j)
  double skin;
  const std::int32_t* species;      // the store's species, or null when i is not of the excluded species
  std::int32_t excluded;            // the excluded species (pairs with both of it are not listed)
};

// x, d: the store's positions (Dim doubles per particle) and diameters.
// Returns the new end of out and adds the pairs in contact to contacts. out
// must have room for e - b + kScanSlack entries (the vector form stores
// whole vectors past the last kept one).
inline constexpr std::uint32_t kScanSlack = 8;
template <int Dim>
GRANULAR_INLINE std::uint32_t* pair_scan_scalar(const double* x, const double* d, std::uint32_t b, std::uint32_t e,
                                                const PairScanRow& row, std::uint32_t* out, std::uint32_t& contacts) {
  for (std::uint32_t j = b; j < e; ++j) {
    double r2 = 0.0;
    for (int a = 0; a < Dim; ++a) {
      const double da = row.xs[a] - x[Dim * j + a];
      r2 = std::fma(da, da, r2);
    }
    const double r0 = row.factor * (row.di + d[j]), rc = r0 + row.skin;
    const bool hit = (r2 < rc * rc) & !(row.species && row.species[j] == row.excluded);
    *out = j;
    out += hit;
    contacts += hit & (r2 < r0 * r0);
  }
  return out;
}

#ifdef GRANULAR_RANGE_SCAN_AVX512
// Eight particles' coordinates from their Dim * 8 consecutive doubles: loads
// of whole vectors and a deinterleave (cheaper than gathers).
template <int Dim>
GRANULAR_INLINE void load_coords8(const double* p, __mmask8 m, __m512d (&c)[Dim]);

template <>
GRANULAR_INLINE void load_coords8<3>(const double* p, __mmask8 m, __m512d (&c)[3]) {
  // Mask over the 24 doubles: 3 per particle kept.
  const unsigned m24 = _pdep_u32(m, 0x249249u) * 7u;  // each particle bit -> three bits
  const __m512d a0 = _mm512_maskz_loadu_pd(static_cast<__mmask8>(m24), p);
  const __m512d a1 = _mm512_maskz_loadu_pd(static_cast<__mmask8>(m24 >> 8), p + 8);
  const __m512d a2 = _mm512_maskz_loadu_pd(static_cast<__mmask8>(m24 >> 16), p + 16);
  // x_k at 3k, y_k at 3k + 1, z_k at 3k + 2 of a0 | a1 | a2.
  const __m512d tx = _mm512_permutex2var_pd(a0, _mm512_setr_epi64(0, 3, 6, 9, 12, 15, 0, 0), a1);
  c[0] = _mm512_permutex2var_pd(tx, _mm512_setr_epi64(0, 1, 2, 3, 4, 5, 10, 13), a2);
  const __m512d ty = _mm512_permutex2var_pd(a0, _mm512_setr_epi64(1, 4, 7, 10, 13, 0, 0, 0), a1);
  c[1] = _mm512_permutex2var_pd(ty, _mm512_setr_epi64(0, 1, 2, 3, 4, 8, 11, 14), a2);
  const __m512d tz = _mm512_permutex2var_pd(a0, _mm512_setr_epi64(2, 5, 8, 11, 14, 0, 0, 0), a1);
  c[2] = _mm512_permutex2var_pd(tz, _mm512_setr_epi64(0, 1, 2, 3, 4, 9, 12, 15), a2);
}

template <>
GRANULAR_INLINE void load_coords8<2>(const double* p, __mmask8 m, __m512d (&c)[2]) {
  const unsigned m16 = _pdep_u32(m, 0x5555u) * 3u;  // each particle bit -> two bits
  const __m512d a0 = _mm512_maskz_loadu_pd(static_cast<__mmask8>(m16), p);
  const __m512d a1 = _mm512_maskz_loadu_pd(static_cast<__mmask8>(m16 >> 8), p + 8);
  c[0] = _mm512_permutex2var_pd(a0, _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14), a1);
  c[1] = _mm512_permutex2var_pd(a0, _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15), a1);
}

template <int Dim>
GRANULAR_INLINE std::uint32_t* pair_scan_avx512(const double* x, const double* d, std::uint32_t b, std::uint32_t e,
                                                const PairScanRow& row, std::uint32_t* out, std::uint32_t& contacts) {
  __m512d xv[Dim];
  for (int a = 0; a < Dim; ++a) xv[a] = _mm512_set1_pd(row.xs[a]);
  const __m512d factor = _mm512_set1_pd(row.factor), di = _mm512_set1_pd(row.di), skin = _mm512_set1_pd(row.skin);
  const __m256i excluded = _mm256_set1_epi32(row.excluded);
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  for (std::uint32_t j0 = b; j0 < e; j0 += 8) {
    const std::uint32_t left = e - j0;
    const __mmask8 m = left >= 8 ? static_cast<__mmask8>(0xFF) : static_cast<__mmask8>((1u << left) - 1u);
    __m512d c[Dim];
    load_coords8<Dim>(x + static_cast<std::size_t>(Dim) * j0, m, c);
    __m512d r2 = _mm512_setzero_pd();
    for (int a = 0; a < Dim; ++a) {
      const __m512d da = _mm512_sub_pd(xv[a], c[a]);
      r2 = _mm512_fmadd_pd(da, da, r2);
    }
    const __m512d r0 = _mm512_mul_pd(factor, _mm512_add_pd(di, _mm512_maskz_loadu_pd(m, d + j0)));
    const __m512d rc = _mm512_add_pd(r0, skin);
    __mmask8 keep = _mm512_mask_cmp_pd_mask(m, r2, _mm512_mul_pd(rc, rc), _CMP_LT_OQ);
    if (row.species)
      keep &= static_cast<__mmask8>(
          ~_mm256_cmpeq_epi32_mask(_mm256_maskz_loadu_epi32(m, row.species + j0), excluded));
    contacts += static_cast<std::uint32_t>(
        __builtin_popcount(_mm512_mask_cmp_pd_mask(keep, r2, _mm512_mul_pd(r0, r0), _CMP_LT_OQ)));
    const __m256i j = _mm256_add_epi32(_mm256_set1_epi32(static_cast<int>(j0)), lane);
    // Compress in a register and store all eight lanes: a compress straight
    // to memory is microcoded on some processors (AMD Zen 4) and far slower.
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out), _mm256_maskz_compress_epi32(keep, j));
    out += __builtin_popcount(keep);
  }
  return out;
}
#endif

#ifdef GRANULAR_RANGE_SCAN_AVX2
// Four particles' coordinates from their Dim * 4 consecutive doubles: whole
// loads and a deinterleave within and across the 128-bit halves.
template <int Dim>
GRANULAR_INLINE void load_coords4(const double* p, __m256d (&c)[Dim]);

template <>
GRANULAR_INLINE void load_coords4<3>(const double* p, __m256d (&c)[3]) {
  const __m256d a0 = _mm256_loadu_pd(p);      // x0 y0 | z0 x1
  const __m256d a1 = _mm256_loadu_pd(p + 4);  // y1 z1 | x2 y2
  const __m256d a2 = _mm256_loadu_pd(p + 8);  // z2 x3 | y3 z3
  const __m256d u0 = _mm256_permute2f128_pd(a0, a1, 0x30);  // x0 y0 | x2 y2
  const __m256d u1 = _mm256_permute2f128_pd(a0, a2, 0x21);  // z0 x1 | z2 x3
  const __m256d u2 = _mm256_permute2f128_pd(a1, a2, 0x30);  // y1 z1 | y3 z3
  c[0] = _mm256_blend_pd(u0, u1, 0b1010);
  c[1] = _mm256_shuffle_pd(u0, u2, 0b0101);
  c[2] = _mm256_blend_pd(u1, u2, 0b1010);
}

template <>
GRANULAR_INLINE void load_coords4<2>(const double* p, __m256d (&c)[2]) {
  const __m256d a0 = _mm256_loadu_pd(p);      // x0 y0 | x1 y1
  const __m256d a1 = _mm256_loadu_pd(p + 4);  // x2 y2 | x3 y3
  const __m256d u0 = _mm256_permute2f128_pd(a0, a1, 0x20);  // x0 y0 | x2 y2
  const __m256d u1 = _mm256_permute2f128_pd(a0, a1, 0x31);  // x1 y1 | x3 y3
  c[0] = _mm256_unpacklo_pd(u0, u1);
  c[1] = _mm256_unpackhi_pd(u0, u1);
}

// The lanes a 4-bit mask keeps, in order, packed to the front.
alignas(16) inline constexpr std::int32_t kKeptLanes4[16][4] = {
    {0, 0, 0, 0}, {0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, {2, 0, 0, 0}, {0, 2, 0, 0}, {1, 2, 0, 0}, {0, 1, 2, 0},
    {3, 0, 0, 0}, {0, 3, 0, 0}, {1, 3, 0, 0}, {0, 1, 3, 0}, {2, 3, 0, 0}, {0, 2, 3, 0}, {1, 2, 3, 0}, {0, 1, 2, 3}};

template <int Dim>
GRANULAR_INLINE std::uint32_t* pair_scan_avx2(const double* x, const double* d, std::uint32_t b, std::uint32_t e,
                                              const PairScanRow& row, std::uint32_t* out, std::uint32_t& contacts) {
  __m256d xv[Dim];
  for (int a = 0; a < Dim; ++a) xv[a] = _mm256_set1_pd(row.xs[a]);
  const __m256d factor = _mm256_set1_pd(row.factor), di = _mm256_set1_pd(row.di), skin = _mm256_set1_pd(row.skin);
  const __m128i excluded = _mm_set1_epi32(row.excluded);
  std::uint32_t j0 = b;
  for (; j0 + 4 <= e; j0 += 4) {
    __m256d c[Dim];
    load_coords4<Dim>(x + static_cast<std::size_t>(Dim) * j0, c);
    __m256d r2 = _mm256_setzero_pd();
    for (int a = 0; a < Dim; ++a) {
      const __m256d da = _mm256_sub_pd(xv[a], c[a]);
      r2 = _mm256_fmadd_pd(da, da, r2);
    }
    const __m256d r0 = _mm256_mul_pd(factor, _mm256_add_pd(di, _mm256_loadu_pd(d + j0)));
    const __m256d rc = _mm256_add_pd(r0, skin);
    int keep = _mm256_movemask_pd(_mm256_cmp_pd(r2, _mm256_mul_pd(rc, rc), _CMP_LT_OQ));
    if (row.species)
      keep &= ~_mm_movemask_ps(_mm_castsi128_ps(
          _mm_cmpeq_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(row.species + j0)), excluded)));
    contacts += static_cast<std::uint32_t>(
        __builtin_popcount(keep & _mm256_movemask_pd(_mm256_cmp_pd(r2, _mm256_mul_pd(r0, r0), _CMP_LT_OQ))));
    const __m128i kept = _mm_add_epi32(_mm_set1_epi32(static_cast<int>(j0)),
                                       _mm_load_si128(reinterpret_cast<const __m128i*>(kKeptLanes4[keep])));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out), kept);
    out += __builtin_popcount(keep);
  }
  return pair_scan_scalar<Dim>(x, d, j0, e, row, out, contacts);  // the last 0-3
}
#endif

// The pairs of row i among [b, e) (above).
template <int Dim>
GRANULAR_INLINE std::uint32_t* pair_scan(const double* x, const double* d, std::uint32_t b, std::uint32_t e,
                                         const PairScanRow& row, std::uint32_t* out, std::uint32_t& contacts) {
#if defined(GRANULAR_RANGE_SCAN_AVX512)
  return pair_scan_avx512<Dim>(x, d, b, e, row, out, contacts);
#elif defined(GRANULAR_RANGE_SCAN_AVX2)
  return pair_scan_avx2<Dim>(x, d, b, e, row, out, contacts);
#else
  return pair_scan_scalar<Dim>(x, d, b, e, row, out, contacts);
#endif
}

}  // namespace granular
