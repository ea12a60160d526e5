// The neighbour-list build's inner loop: of the particles in a contiguous
// range [b, e) of the cell-sorted store, write out those within a distance
// of x_i, taking the periodic image x_j + shift. About one candidate in ten
// is kept, so the loop is written to keep the test out of the branch
// predictor: with AVX-512, eight candidates at a time and a compress-store
// of the ones kept; otherwise one at a time, always writing the candidate and
// advancing the output only past a kept one. Both give the same particles in
// the same order (tests/native/test_neighbors.cpp runs both).
//
// The distance here is a filter, not the contact test: the caller passes the
// largest cutoff i can have with any partner and applies the exact one to the
// survivors, so a last-bit difference from fused multiply-adds cannot drop a
// pair (the caller's cutoff carries a relative margin of 1e-12).
#pragma once
#include <cstdint>

#include "core/space.hpp"

#if defined(__AVX512F__) && defined(__BMI2__) && !defined(GRANULAR_NO_SIMD)
#include <immintrin.h>
#define GRANULAR_RANGE_SCAN_AVX512 1
#endif

namespace granular {

// x: the store's positions as Dim doubles per particle. xs = x_i - shift.
// Returns the new end of out. out must have room for e - b + kScanSlack
// entries (the vector form stores whole vectors past the last kept one).
inline constexpr std::uint32_t kScanSlack = 8;
template <int Dim>
GRANULAR_INLINE std::uint32_t* range_scan_scalar(const double* x, std::uint32_t b, std::uint32_t e, const double* xs,
                                                 double cut2, std::uint32_t* out) {
  for (std::uint32_t j = b; j < e; ++j) {
    double r2 = 0.0;
    for (int a = 0; a < Dim; ++a) {
      const double da = xs[a] - x[Dim * j + a];
      r2 += da * da;
    }
    *out = j;
    out += r2 < cut2;
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
GRANULAR_INLINE std::uint32_t* range_scan_avx512(const double* x, std::uint32_t b, std::uint32_t e, const double* xs,
                                                 double cut2, std::uint32_t* out) {
  __m512d xv[Dim];
  for (int a = 0; a < Dim; ++a) xv[a] = _mm512_set1_pd(xs[a]);
  const __m512d cut = _mm512_set1_pd(cut2);
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
    const __mmask8 keep = _mm512_mask_cmp_pd_mask(m, r2, cut, _CMP_LT_OQ);
    const __m256i j = _mm256_add_epi32(_mm256_set1_epi32(static_cast<int>(j0)), lane);
    // Compress in a register and store all eight lanes: a compress straight
    // to memory is microcoded on some processors (AMD Zen 4) and far slower.
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out), _mm256_maskz_compress_epi32(keep, j));
    out += __builtin_popcount(keep);
  }
  return out;
}
#endif

// Candidates j in [b, e) with |x_i - shift - x_j|^2 < cut2 (a filter: see above).
template <int Dim>
GRANULAR_INLINE std::uint32_t* range_scan(const double* x, std::uint32_t b, std::uint32_t e, const double* xs,
                                          double cut2, std::uint32_t* out) {
#ifdef GRANULAR_RANGE_SCAN_AVX512
  return range_scan_avx512<Dim>(x, b, e, xs, cut2, out);
#else
  return range_scan_scalar<Dim>(x, b, e, xs, cut2, out);
#endif
}

}  // namespace granular
