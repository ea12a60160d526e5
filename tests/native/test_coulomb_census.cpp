// The census of contacts at the Coulomb cap (engine/coulomb_census.hpp):
// counted exactly where min(viscous, mu |F_n|) picks the cap, per species
// pair and per wall species, without touching the run's forces.
#include <gtest/gtest.h>

#include "boundary/cylinder_wall.hpp"
#include "contact/linear.hpp"
#include "contact/poeschel_herrmann.hpp"
#include "contact/viscel.hpp"
#include "engine/coulomb_census.hpp"
#include "engine/simulation.hpp"
#include "integrate/leapfrog.hpp"

using namespace granular;

namespace {

template <class Sim>
void open_box(Sim& sim, double half = 20.0) {
  sim.domain.lo = Sim::V::Constant(-half);
  sim.domain.hi = Sim::V::Constant(half);
  sim.domain.finalize();
  sim.skin = 0.1;
  sim.integrator.dt = 1e-4;
}

// Linear law, d = 1, m = 1: m_eff = 1/2. Overlap 0.01 gives F_n = k_n 0.01 = 100,
// the cap 50; the viscous force x_t g_n m_eff |v_t| = 5 |v_t|, so the cap binds
// above |v_t| = 10.
LinearLaw<3>::Coeff coeff() { return {1e4, 10.0, 1.0, 0.5}; }

using PairSim = Simulation<3, LinearLaw<3>, Leapfrog<3>>;

PairSim sliding_pair(double vt, int ci, int cj) {
  PairSim sim;
  open_box(sim);
  for (auto& c : sim.law.pair) c = coeff();
  sim.p.add({-0.495, 0, 0}, {0, 0.5 * vt, 0}, Ang<3>::Zero(), 1.0, 1.0, 0.1, ci);
  sim.p.add({0.495, 0, 0}, {0, -0.5 * vt, 0}, Ang<3>::Zero(), 1.0, 1.0, 0.1, cj);
  sim.init();
  return sim;
}

TEST(CoulombCensus, PairBelowTheCapIsNotCounted) {
  const auto sim = sliding_pair(5.0, 0, 1);
  const auto c = coulomb_census(sim);
  EXPECT_EQ(c.pair_contacts[0 * 2 + 1], 1.0);
  EXPECT_EQ(c.pair_at_cap[0 * 2 + 1], 0.0);
}

TEST(CoulombCensus, PairAboveTheCapIsCountedUnderItsSpeciesPair) {
  const auto sim = sliding_pair(20.0, 1, 0);  // species given in the other order: same key
  const auto c = coulomb_census(sim);
  EXPECT_EQ(c.pair_contacts[0 * 2 + 1], 1.0);
  EXPECT_EQ(c.pair_at_cap[0 * 2 + 1], 1.0);
  EXPECT_EQ(c.pair_contacts[1 * 2 + 1] + c.pair_contacts[0], 0.0);
}

TEST(CoulombCensus, JustBelowAndJustAboveTheThreshold) {
  EXPECT_EQ(coulomb_census(sliding_pair(9.9, 0, 0)).pair_at_cap[0], 0.0);
  EXPECT_EQ(coulomb_census(sliding_pair(10.1, 0, 0)).pair_at_cap[0], 1.0);
}

TEST(CoulombCensus, SeparatedPairsAreNotContacts) {
  PairSim sim;
  open_box(sim);
  for (auto& c : sim.law.pair) c = coeff();
  sim.p.add({-0.52, 0, 0}, {0, 5, 0}, Ang<3>::Zero(), 1.0, 1.0, 0.1, 0);
  sim.p.add({0.52, 0, 0}, {0, -5, 0}, Ang<3>::Zero(), 1.0, 1.0, 0.1, 0);
  sim.init();
  const auto c = coulomb_census(sim);
  EXPECT_EQ(c.pair_contacts[0], 0.0);
}

// A particle of diameter 1 pressed into a cylinder wall (zero thickness) of
// diameter 10 rotating at omega: the wall slides past it at 5 omega.
template <class Law>
Simulation<3, Law, Leapfrog<3>, CylinderWall> against_wall(double omega, const Law& law) {
  Simulation<3, Law, Leapfrog<3>, CylinderWall> sim;
  open_box(sim);
  sim.law = law;
  auto& cyl = std::get<CylinderWall>(sim.walls);
  cyl.diameter = 10.0;
  cyl.omega = omega;
  cyl.d_wall = 0.0;
  sim.p.add({0, 0, -4.51}, Vec<3>::Zero(), Ang<3>::Zero(), 1.0, 1.0, 0.1, 1);
  sim.init();
  return sim;
}

TEST(CoulombCensus, WallContactsPerSpeciesAndTheRunsForcesUntouched) {
  LinearLaw<3> law;
  for (auto& c : law.wall) c = {1e4, 10.0, 1.0, 0.5};  // m_eff = m = 1: viscous 10 |v_t|, F_n = 100, cap 50
  const auto slow = against_wall(0.8, law);           // |v_t| = 4: 40 < 50
  const auto fast = against_wall(1.2, law);           // |v_t| = 6: 60 > 50
  const auto a = coulomb_census(slow), b = coulomb_census(fast);
  EXPECT_EQ(a.wall_contacts[1], 1.0);
  EXPECT_EQ(a.wall_at_cap[1], 0.0);
  EXPECT_EQ(b.wall_contacts[1], 1.0);
  EXPECT_EQ(b.wall_at_cap[1], 1.0);
  EXPECT_EQ(b.wall_contacts[0], 0.0);
  auto again = against_wall(1.2, law);
  const auto f0 = again.p.f[0];
  coulomb_census(again);
  EXPECT_EQ(again.p.f[0], f0);
}

TEST(CoulombCensus, UncappedLawCountsWhereTheMappedCapWouldBind) {
  ViscElLaw<3> law;
  law.mat[1] = {0, 0, 0};
  law.wall[1] = {1e4, 0.0, 10.0};  // F_n = 100, F_t = 10 |v_t|, never capped
  law.wall_mu_ref[1] = 0.5;
  const auto slow = against_wall(0.8, law), fast = against_wall(1.2, law);
  EXPECT_EQ(coulomb_census(slow).wall_at_cap[1], 0.0);
  EXPECT_EQ(coulomb_census(fast).wall_at_cap[1], 1.0);
  // The law itself stays uncapped: |F_t| = 60 > mu F_n = 50.
  const Vec<3> ft = fast.p.f[0] - fast.p.f[0].dot(Vec<3>::UnitZ()) * Vec<3>::UnitZ();
  EXPECT_NEAR(ft.norm(), 60.0, 1e-9);
}

TEST(CoulombCensus, DisksWithWallParticlesUseTheThreeSpeciesKey) {
  Simulation<2, PoeschelHerrmannLaw<2>, Leapfrog<2>> sim;
  open_box(sim);
  sim.law.young = 3e6;
  sim.law.gamma_n = 100;
  sim.law.gamma_s = 1;
  sim.law.mu = 0.5;
  // a grain and a wall particle (species 2): overlap 0.01, F_n = 3e4; the
  // viscous force gamma_S m_eff |v| reaches the cap 1.5e4 only at |v| ~ 2e3
  const double m = 2 * M_PI;
  sim.p.add({-0.995, 0}, {0, 1.0}, Ang<2>::Zero(), 2.0, m, 0.5 * m, 0);
  sim.p.add({0.995, 0}, {0, 0}, Ang<2>::Zero(), 2.0, m, 0.5 * m, 2);
  sim.init();
  const auto c = coulomb_census(sim);
  EXPECT_EQ(c.species, 3);
  EXPECT_EQ(c.pair_contacts[0 * 3 + 2], 1.0);
  EXPECT_EQ(c.pair_at_cap[0 * 3 + 2], 0.0);
  sim.p.v[0] = {0, 1e4};
  EXPECT_EQ(coulomb_census(sim).pair_at_cap[0 * 3 + 2], 1.0);
}

}  // namespace
