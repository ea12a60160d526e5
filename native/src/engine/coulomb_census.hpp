// How often the Coulomb cap binds: a diagnostic taken at output times, outside
// the time step (the step itself carries no counters).
//
// Every law here writes a contact force as F = F_n n + F_t with F_t
// perpendicular to n, so the census evaluates the scene's own law on each
// contact of the current state and counts the contacts with
//   |F_t| >= (1 - 1e-9) mu |F_n|,  |F_t| > 0.
// For a capped law (Rapaport Eq. (4)/(5), Poeschel & Herrmann Eq. (3), the
// linear law) that is the set where the cap is active; for YADE's uncapped law
// (contact/viscel.hpp) it is the set where a cap with the mapped law's mu would
// have bound. Pairs are counted per unordered species pair, wall contacts per
// species; the walls are evaluated on a copy of the particles, so the state of
// the run is untouched. A wall that evaluates the pair law against a virtual
// wall particle (boundary/flat_box_walls.hpp) is counted as that pair, with the
// wall particle's species, as a wall of particles would be.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <tuple>
#include <vector>

#include "core/threads.hpp"
#include "io/h5_output.hpp"

namespace granular {

struct CoulombCensus {
  int species = 0;
  std::vector<double> pair_contacts, pair_at_cap;  // [min(ci,cj) * species + max(ci,cj)]
  std::vector<double> wall_contacts, wall_at_cap;  // [ci]
};

namespace census_detail {

template <class V>
bool at_cap(const V& f, const V& n, double mu) {
  const double fn = f.dot(n);
  const double ft = (f - fn * n).norm();
  return ft > 0.0 && ft >= (1.0 - 1e-9) * mu * std::abs(fn);
}

// The scene's law seen through the walls' interface; records each wall contact.
template <class Law>
struct CountingLaw {
  const Law& law;
  CoulombCensus& c;
  static constexpr bool kVectorised = false;  // one contact at a time, each recorded
  GRANULAR_INLINE static double range(double a, double b) { return Law::range(a, b); }
  template <class V, class A, class L>
  auto wall_force(const V& rp, double di, double d_iw, const V& viw, const A& wi, const L& lever, int ci,
                  double inv_mi) const {
    const auto res = law.wall_force(rp, di, d_iw, viw, wi, lever, ci, inv_mi);
    c.wall_contacts[ci] += 1.0;
    if (at_cap(res.f, V(rp / rp.norm()), law.wall_coulomb_mu(ci))) c.wall_at_cap[ci] += 1.0;
    return res;
  }
  template <class V, class A>
  auto pair_force(const V& dr, double r2, double di, double dj, const V& vij, const A& wi, const A& wj, int ci,
                  int cj, double inv_mi, double inv_mj) const {
    const auto res = law.pair_force(dr, r2, di, dj, vij, wi, wj, ci, cj, inv_mi, inv_mj);
    const int key = std::min(ci, cj) * Law::kSpecies + std::max(ci, cj);
    c.pair_contacts[key] += 1.0;
    if (at_cap(res.f, V(dr / std::sqrt(r2)), law.coulomb_mu(ci, cj))) c.pair_at_cap[key] += 1.0;
    return res;
  }
};

}  // namespace census_detail

template <class Sim>
CoulombCensus coulomb_census(const Sim& sim) {
  using Law = decltype(sim.law);
  constexpr int S = Law::kSpecies;
  CoulombCensus c;
  c.species = S;
  c.pair_contacts.assign(S * S, 0.0);
  c.pair_at_cap.assign(S * S, 0.0);
  c.wall_contacts.assign(S, 0.0);
  c.wall_at_cap.assign(S, 0.0);
  const auto& p = sim.p;
  const auto& nl = sim.neighbors();
  const std::size_t n = p.size();
  for (int t = 0; t < nl.threads(); ++t) {
    const auto [lo, hi] = nl.row_block(t);
    const std::uint32_t* col = nl.col(t);
    for (std::size_t i = lo; i < hi; ++i)
      for (std::uint32_t k = nl.begin(i), ke = nl.end(i); k < ke; ++k) {
        const std::uint32_t j = col[k];
        const auto dr = sim.domain.min_image(p.x[i] - p.x[j]);
        const double r2 = dr.squaredNorm();
        const double rc = Law::range(p.d[i], p.d[j]);
        if (r2 >= rc * rc) continue;
        const int ci = p.species[i], cj = p.species[j];
        const auto res = sim.law.pair_force(dr, r2, p.d[i], p.d[j], p.v[i] - p.v[j], p.w[i], p.w[j], ci, cj,
                                            p.inv_m[i], p.inv_m[j]);
        const int key = std::min(ci, cj) * S + std::max(ci, cj);
        c.pair_contacts[key] += 1.0;
        if (census_detail::at_cap(res.f, decltype(dr)(dr / std::sqrt(r2)), sim.law.coulomb_mu(ci, cj)))
          c.pair_at_cap[key] += 1.0;
      }
  }
  if constexpr (std::tuple_size_v<decltype(sim.walls)> > 0) {
    auto q = p;  // the walls add to q's forces, not the run's
    const census_detail::CountingLaw<Law> counting{sim.law, c};
    std::apply([&](const auto&... w) { (w.apply(q, counting, 0, n, sim.time), ...); }, sim.walls);
  }
  return c;
}

// The census as the group "coulomb" of the output (docs/output_schema.md).
inline int init_census(H5Output& out, int species) {
  const int h = out.init_series("coulomb", {{"time", 1},
                                            {"pair_contacts", species * species},
                                            {"pair_at_cap", species * species},
                                            {"wall_contacts", species},
                                            {"wall_at_cap", species}});
  return h;
}

inline void write_census(H5Output& out, int handle, double time, const CoulombCensus& c) {
  out.series(handle, {{time}, c.pair_contacts, c.pair_at_cap, c.wall_contacts, c.wall_at_cap});
}

}  // namespace granular
