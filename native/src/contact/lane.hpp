// One contact as plain values: what a contact law's equations take and give.
//
// Each law (contact/*.hpp) writes its equations once, as two lane functions
// on these structs,
//
//   void pair_lane(const PairContact<Dim>&, PairForce<Dim>&) const    particle-particle
//   void wall_lane(const WallContact<Dim>&, WallForce<Dim>&) const    particle-wall
//
// doubles in, doubles out: no Eigen temporaries, nothing a vectorising
// compiler or a GPU compiler cannot take. Every path is built from them
// (contact/law_paths.hpp): one contact at a time with Eigen vectors, many
// contacts in SIMD lanes over a batch in columns (contact/pair_batch.hpp,
// contact/wall_batch.hpp), and, marked GRANULAR_HD, a GPU kernel. The lane
// helpers below (dot product, omega x r, r x f, the capped viscous friction)
// are shared by the laws.
#pragma once
#include <algorithm>
#include <cmath>

// Host and device: a lane function is compiled for the CPU loops and, by
// nvcc, for GPU kernels (HOOMD-blue's DEVICE / HOSTDEVICE idea; nvcc takes
// std::min, std::sqrt and std::array's [] with --expt-relaxed-constexpr).
#if defined(__CUDACC__)
#define GRANULAR_HD __host__ __device__ __forceinline__
#else
#define GRANULAR_HD inline __attribute__((always_inline))
#endif

namespace granular {

// Components of an angular velocity or torque: 3 in 3D, the z component in 2D.
template <int Dim>
inline constexpr int kAngDim = Dim == 3 ? 3 : 1;

// A particle-particle contact: i and j, dr = r_i - r_j after minimum image,
// r2 = |dr|^2 (in range: r2 < range(d_i, d_j)^2), v = v_i - v_j.
template <int Dim>
struct PairContact {
  double dr[Dim];
  double r2;
  double di, dj;
  double v[Dim];
  double wi[kAngDim<Dim>], wj[kAngDim<Dim>];
  int ci, cj;  // species
  double inv_mi, inv_mj;
};

// The force on i (j gets -f) and the torques on i and on j.
template <int Dim>
struct PairForce {
  double f[Dim];
  double ti[kAngDim<Dim>], tj[kAngDim<Dim>];
};

// A particle-wall contact: rp = r'_iw from the wall's contact point to the
// particle; d_iw = (d_i + d_w)/2; v = v_i - the wall's velocity there; lever
// is the vector that multiplies w_i in the sliding velocity
// (boundary/wall_contact.hpp); the wall's mass is infinite.
template <int Dim>
struct WallContact {
  double rp[Dim];
  double di, d_iw;
  double v[Dim];
  double w[kAngDim<Dim>];
  double lever[Dim];
  int ci;
  double inv_mi;
};

// The force and torque on the particle.
template <int Dim>
struct WallForce {
  double f[Dim];
  double t[kAngDim<Dim>];
};

template <int N>
GRANULAR_HD double lane_dot(const double (&a)[N], const double (&b)[N]) {
  double s = a[0] * b[0];
  for (int k = 1; k < N; ++k) s += a[k] * b[k];
  return s;
}

// omega x r: angular velocity times a position vector gives a velocity.
GRANULAR_HD void spin_cross_c(const double (&w)[3], const double (&r)[3], double (&out)[3]) {
  out[0] = w[1] * r[2] - w[2] * r[1];
  out[1] = w[2] * r[0] - w[0] * r[2];
  out[2] = w[0] * r[1] - w[1] * r[0];
}
GRANULAR_HD void spin_cross_c(const double (&w)[1], const double (&r)[2], double (&out)[2]) {
  out[0] = -w[0] * r[1];
  out[1] = w[0] * r[0];
}

// r x f: a lever arm times a force gives a torque.
GRANULAR_HD void moment_c(const double (&r)[3], const double (&f)[3], double (&out)[3]) {
  out[0] = r[1] * f[2] - r[2] * f[1];
  out[1] = r[2] * f[0] - r[0] * f[2];
  out[2] = r[0] * f[1] - r[1] * f[0];
}
GRANULAR_HD void moment_c(const double (&r)[2], const double (&f)[2], double (&out)[1]) {
  out[0] = r[0] * f[1] - r[1] * f[0];
}

// The capped viscous friction of Rapaport's and the linear law, pairs and
// walls: f = -min(g |v|, mu |f_n|) v/|v|, zero at v = 0 (v2 = |v|^2,
// mu_fn = mu |f_n|). -min(...) / |v|, and +0 at v = 0 (then the min is 0,
// so 0 / 1), written without a select around the division: a division under
// a condition keeps a SIMD loop scalar without AVX-512's masked lanes (GCC
// 12, AVX2: "control flow in loop").
template <int N>
GRANULAR_HD void capped_friction_c(const double (&v)[N], double v2, double g, double mu_fn, double (&f)[N]) {
  const double vabs = std::sqrt(v2);
  const double mag = std::min(g * vabs, mu_fn);
  const double scale = (0.0 - mag) / (vabs + static_cast<double>(v2 == 0.0));
  for (int a = 0; a < N; ++a) f[a] = scale * v[a];
}

}  // namespace granular
