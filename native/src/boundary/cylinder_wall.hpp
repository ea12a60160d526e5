// The drum's curved wall: Rapaport (2002), Sec. III. Axis along y through the
// origin, diameter D, smooth wall of "diameter" d_w = 1 rotating with angular
// velocity Omega. For particle i:
//   r_iw  = r_i - (r_i . y^) y^,  in range if r_iw > D/2 - 2^(1/6) d_iw, d_iw = (d_i + d_w)/2
//   r'_iw = (1 - D / 2 r_iw) r_iw                    (wall contact point -> particle)
//   s     = (D/2) r^_iw x y^,  v_iw = v_i - Omega s
//   v^s_iw = v_iw - (r^ . v_iw) r^ - w_i x r'_iw       then Eq. (5)
// lever reading: "paper" uses w_i x r'_iw as printed; "pair" uses Eq. (3) with the
// wall as a resting particle of diameter d_w, i.e. d_i/(d_i + d_w) w_i x r'_iw.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "boundary/wall_contact.hpp"

namespace granular {

struct CylinderWall {
  double diameter = 16.0;  // D
  double omega = 0.5;      // Omega
  double d_wall = 1.0;     // d_w
  WallLever lever;         // reading of the spin term, see wall_contact.hpp
  // Cost per particle in listed pairs (for the threads' blocks,
  // neighbor/neighbor_list.hpp): 7 ns in drum #A with the law's batch
  // kernel (5 % of a step; 17 ns, 13 %, one by one).
  static constexpr unsigned kWeight = 3;

  // The time of the positions (the wall interface, engine/simulation.hpp) is not
  // needed: the wall turns about its own axis, so its surface never moves.
  // In two passes over blocks of particles: first the ones within reach of
  // the wall, without a branch (a fifth of the particles touch the wall, in
  // no pattern a branch predictor could follow), then their contacts: in
  // batches through the law's vectorised kernel where it has one
  // (contact/wall_batch.hpp), else one by one.
  template <class Law>
  void apply(ParticleStore<3>& p, const Law& law, std::size_t lo, std::size_t hi, double /*t*/) const {
    constexpr std::size_t kBlock = 256;
    std::uint32_t near[kBlock];
    [[maybe_unused]] WallBatch<3> b;
    for (std::size_t b0 = lo; b0 < hi; b0 += kBlock) {
      const std::size_t m = select_near<Law>(p, b0, std::min(hi, b0 + kBlock), near);
      if constexpr (HasWallBatch<Law, 3>::value) {
        for (std::size_t k = 0; k < m; ++k) {
          if (b.n == WallBatch<3>::kSize) flush(p, law, b);
          gather(p, near[k], b);
        }
      } else {
        for (std::size_t k = 0; k < m; ++k) contact(p, law, near[k]);
      }
    }
    if constexpr (HasWallBatch<Law, 3>::value)
      if (b.n > 0) flush(p, law, b);
  }

  // Whether a particle at (x, ., z) of diameter d_i is within the law's
  // reach of the wall: r_iw > D/2 - range(d_i, d_w). Host and device
  // (GRANULAR_HD): the GPU drum (gpu/drum_kernels.hpp) tests the same way.
  template <class Law>
  GRANULAR_HD bool in_reach(double x, double z, double di) const {
    const double half_d = 0.5 * diameter;
    const double rr = x * x + z * z;
    const double reach = half_d - Law::range(di, d_wall);
    return rr > reach * reach;
  }

  // The contact's geometry from the header's equations, for a particle at
  // (x, ., z) of diameter d_i moving at (vx, vy, vz): r'_iw into rp, v_i -
  // Omega (D/2) r^_iw x y^ into v, the lever multiplying w_i into lv, and
  // d_iw. Host and device: the CPU batches (flush) and the GPU drum compute
  // the same numbers.
  GRANULAR_HD void geometry(double x, double z, double di, double vx, double vy, double vz, double (&rp)[3],
                            double (&v)[3], double (&lv)[3], double& d_iw) const {
    const double half_d = 0.5 * diameter;
    const double r = std::sqrt(x * x + z * z);
    const double scale = 1.0 - half_d / r;
    rp[0] = scale * x;  // r'_iw
    rp[1] = scale * 0.0;
    rp[2] = scale * z;
    v[0] = vx - omega * (-half_d * z / r);  // v_i - Omega (D/2) r^_iw x y^
    v[1] = vy - omega * 0.0;
    v[2] = vz - omega * (half_d * x / r);
    const double arm = lever.arm(di, d_wall);
    for (int a = 0; a < 3; ++a) lv[a] = arm * rp[a];
    d_iw = 0.5 * (di + d_wall);
  }

 private:
  // The particles of [b0, b1) within reach of the wall, into near; returns how many.
  template <class Law>
  std::size_t select_near(const ParticleStore<3>& p, std::size_t b0, std::size_t b1, std::uint32_t* near) const {
    std::size_t m = 0;
    for (std::size_t i = b0; i < b1; ++i) {
      const Eigen::Vector3d& x = p.x[i];
      near[m] = static_cast<std::uint32_t>(i);
      m += in_reach<Law>(x.x(), x.z(), p.d[i]);
    }
    return m;
  }

  // One contact, r'_iw and the wall's velocity from the header's equations.
  template <class Law>
  void contact(ParticleStore<3>& p, const Law& law, std::size_t i) const {
    const double half_d = 0.5 * diameter;
    const Eigen::Vector3d& x = p.x[i];
    const double r = std::sqrt(x.x() * x.x() + x.z() * x.z());
    const Eigen::Vector3d riw(x.x(), 0.0, x.z());
    const Eigen::Vector3d rp = (1.0 - half_d / r) * riw;                      // r'_iw
    const Eigen::Vector3d s(-half_d * x.z() / r, 0.0, half_d * x.x() / r);   // (D/2) r^_iw x y^
    wall_contact(p, law, i, rp, omega * s, d_wall, lever);
  }

  // Particle i's state into the next lane of b, as it is (flush turns it into
  // the contact's geometry).
  static void gather(const ParticleStore<3>& p, std::uint32_t i, WallBatch<3>& b) {
    const int q = b.n++;
    b.i[q] = i;
    b.ci[q] = p.species[i];
    for (int a = 0; a < 3; ++a) {
      b.rp[a][q] = p.x[i][a];
      b.v[a][q] = p.v[i][a];
      b.w[a][q] = p.w[i][a];
    }
    b.di[q] = p.d[i];
    b.inv_mi[q] = p.inv_m[i];
  }

  // The geometry of contact(), lane by lane (the same expressions, so the
  // same numbers), then the law's kernel, then the sums.
  template <class Law>
  void flush(ParticleStore<3>& p, const Law& law, WallBatch<3>& b) const {
    const int nb = b.n;
#pragma omp simd
    for (int k = 0; k < nb; ++k) {
      double rp[3], v[3], lv[3];
      geometry(b.rp[0][k], b.rp[2][k], b.di[k], b.v[0][k], b.v[1][k], b.v[2][k], rp, v, lv, b.d_iw[k]);
      for (int a = 0; a < 3; ++a) {
        b.rp[a][k] = rp[a];
        b.v[a][k] = v[a];
        b.lever[a][k] = lv[a];
      }
    }
    flush_wall_contacts(p, law, b);
  }
};

}  // namespace granular
