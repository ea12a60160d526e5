// The paths every contact law gets from its two lane functions
// (contact/lane.hpp), so that its equations are written once:
//
// - pair_force / wall_force: one contact at a time, on Eigen vectors (the
//   pair loop for laws that do not run in SIMD batches, particle walls, the
//   Coulomb census, tests);
// - pair_force_batch / wall_force_batch: a batch of contacts in columns, in
//   SIMD lanes (contact/pair_batch.hpp, contact/wall_batch.hpp);
// - a GPU kernel calls the same lane functions (they are GRANULAR_HD).
//
// A law derives from LawPaths<Law, Dim> (the curiously recurring template
// pattern: the paths call the derived law's lanes, inlined, no virtual call).
#pragma once
#include "contact/lane.hpp"
#include "contact/pair_batch.hpp"
#include "contact/wall_batch.hpp"
#include "core/space.hpp"

namespace granular {

// A law set from a scene's parameters, with the contact geometry it needs
// (contact/*.hpp from_rapaport; engine/contact_setup.hpp applies it): the
// factor on the particles' diameters, how far each wall surface moves towards
// the particles, and the wall diameter d_w the law sees.
template <class Law>
struct MappedLaw {
  Law law;
  double diameter_scale = 1.0;
  double wall_inset = 0.0;
  double d_wall = 0.0;
};

template <class Law, int Dim>
struct LawPaths {
  using V = Vec<Dim>;
  using A = Ang<Dim>;

  struct PairResult {
    V f;   // force on i (j gets -f)
    A ti;  // torque on i
    A tj;  // torque on j
  };
  struct WallResult {
    V f;
    A t;
  };

  // dr = r_i - r_j after minimum image, r2 = |dr|^2 < range(d_i, d_j)^2, vij = v_i - v_j.
  GRANULAR_INLINE PairResult pair_force(const V& dr, double r2, double di, double dj, const V& vij, const A& wi,
                                        const A& wj, int ci, int cj, double inv_mi, double inv_mj) const {
    PairContact<Dim> c;
    for (int a = 0; a < Dim; ++a) {
      c.dr[a] = dr[a];
      c.v[a] = vij[a];
    }
    for (int a = 0; a < kAngDim<Dim>; ++a) {
      c.wi[a] = wi[a];
      c.wj[a] = wj[a];
    }
    c.r2 = r2;
    c.di = di;
    c.dj = dj;
    c.ci = ci;
    c.cj = cj;
    c.inv_mi = inv_mi;
    c.inv_mj = inv_mj;
    PairForce<Dim> o;
    law().pair_lane(c, o);
    PairResult r;
    for (int a = 0; a < Dim; ++a) r.f[a] = o.f[a];
    for (int a = 0; a < kAngDim<Dim>; ++a) {
      r.ti[a] = o.ti[a];
      r.tj[a] = o.tj[a];
    }
    return r;
  }

  // rp = r'_iw from the wall's contact point to the particle, d_iw = (d_i + d_w)/2,
  // viw = v_i - the wall's velocity there, lever multiplies w_i in the sliding
  // velocity (boundary/wall_contact.hpp).
  GRANULAR_INLINE WallResult wall_force(const V& rp, double di, double d_iw, const V& viw, const A& wi,
                                        const V& lever, int ci, double inv_mi) const {
    WallContact<Dim> c;
    for (int a = 0; a < Dim; ++a) {
      c.rp[a] = rp[a];
      c.v[a] = viw[a];
      c.lever[a] = lever[a];
    }
    for (int a = 0; a < kAngDim<Dim>; ++a) c.w[a] = wi[a];
    c.di = di;
    c.d_iw = d_iw;
    c.ci = ci;
    c.inv_mi = inv_mi;
    WallForce<Dim> o;
    law().wall_lane(c, o);
    WallResult r;
    for (int a = 0; a < Dim; ++a) r.f[a] = o.f[a];
    for (int a = 0; a < kAngDim<Dim>; ++a) r.t[a] = o.t[a];
    return r;
  }

  void pair_force_batch(PairBatch<Dim>& b) const { granular::pair_force_batch(law(), b); }
  void wall_force_batch(WallBatch<Dim>& b) const { granular::wall_force_batch(law(), b); }

 private:
  GRANULAR_INLINE const Law& law() const { return static_cast<const Law&>(*this); }
};

}  // namespace granular
