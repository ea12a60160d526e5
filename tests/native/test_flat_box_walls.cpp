// The shaken box's smooth walls (boundary/flat_box_walls.hpp): the pair law of
// Poeschel and Herrmann (1995, Eqs. (1)-(6)) against a virtual wall particle
// behind a flat surface that moves with the shaker. Checked against the
// analytic linear-oscillator collision, against a real wall particle under
// the grain, against the shaker's motion, and against the law's normal and
// capped tangential forces written out again here.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "boundary/flat_box_walls.hpp"
#include "contact/poeschel_herrmann.hpp"
#include "engine/box.hpp"
#include "engine/simulation.hpp"
#include "integrate/gear.hpp"
#include "integrate/leapfrog.hpp"
#include "integrate/motion.hpp"

using namespace granular;

namespace {

constexpr double kY = 3e6, kGammaN = 100.0, kGammaS = 1.0, kMu = 0.5, kG = 981.0;
using Law = PoeschelHerrmannLaw<2>;

double disk_mass(double r) { return 2.0 * M_PI * r * r; }  // m = 2 pi R^2 rho, rho = 1 (paper)

template <class Sim>
void set_up(Sim& sim, double dt, double gravity) {
  sim.domain.lo = Eigen::Vector2d(-40, -40);
  sim.domain.hi = Eigen::Vector2d(40, 40);
  sim.domain.finalize();
  sim.skin = 0.2;
  sim.law.young = kY;
  sim.law.gamma_n = kGammaN;
  sim.law.gamma_s = kGammaS;
  sim.law.mu = kMu;
  sim.integrator.dt = dt;
  sim.integrator.gravity = Eigen::Vector2d(0, -gravity);
}

void add_disk(ParticleStore<2>& p, Eigen::Vector2d x, Eigen::Vector2d v, double r, int species = 0, double w = 0.0) {
  const double m = disk_mass(r);
  Ang<2> om;
  om[0] = w;
  p.add(x, v, om, 2 * r, m, 0.5 * m * r * r, species);
}

ShakerMotion<2> shaker(double amplitude, double f, double start) {
  ShakerMotion<2> m;
  m.amplitude = amplitude;
  m.f0 = m.f1 = f;
  m.start = start;
  m.startup_cycles = 2.0;
  return m;
}

constexpr double kHalfWidth = 20.0, kRw = 1.0;

// The floor or a wall particle directly beneath the grain at (x0, .): the two
// ways a box can hold it. wall_inv_mass: 1/m_w, 0 for infinitely heavy.
template <template <int, class> class Integrator>
struct Floors {
  using Flat = Simulation<2, Law, Integrator<2, NoMotion>, FlatBoxWalls>;
  using Particle = Simulation<2, Law, Integrator<2, ShakerMotion<2>>>;

  static void flat(Flat& sim, const ShakerMotion<2>& m, double wall_inv_mass) {
    FlatBoxWalls& w = std::get<FlatBoxWalls>(sim.walls);
    w.half_width = kHalfWidth;
    w.wall_radius = kRw;
    w.wall_inv_mass = wall_inv_mass;
    w.side_top = 30.0;
    w.shaker = m;
  }
  static void particle(Particle& sim, const ShakerMotion<2>& m, double wall_inv_mass, double x0) {
    sim.integrator.motion = m;
    sim.integrator.motion.anchor = {Eigen::Vector2d(x0, -kRw)};  // id 0: centre r_w under the surface y = 0
    add_disk(sim.p, {x0, -kRw}, {0, 0}, kRw, kWallSpecies);
    sim.p.inv_m[0] = wall_inv_mass;
    sim.exclude_species = kWallSpecies;
  }
};

// The grain (the store's one particle that is not a wall particle).
template <class Sim>
std::size_t grain(const Sim& sim) {
  for (std::size_t i = 0; i < sim.p.size(); ++i)
    if (sim.p.species[i] != kWallSpecies) return i;
  return sim.p.size();
}

struct Bounce {
  double restitution, contact_time, x, vx;
};

// A grain dropped at v0 onto the floor at rest, no gravity: the outgoing
// speed over the incoming and the time with overlap (start and end
// interpolated linearly within their steps).
template <class Sim>
Bounce bounce(Sim& sim, double r, double v0) {
  auto gap = [&] { return sim.p.x[grain(sim)].y() - r; };  // to the floor surface y = 0
  double t_in = -1, t_out = -1, prev_gap = gap(), prev_t = sim.time;
  for (int k = 0; k < 200000 && t_out < 0; ++k) {
    sim.step();
    const double g = gap();
    if (t_in < 0 && g < 0) t_in = prev_t + (sim.time - prev_t) * prev_gap / (prev_gap - g);
    if (t_in >= 0 && g > 0) t_out = prev_t + (sim.time - prev_t) * (-prev_gap) / (g - prev_gap);
    prev_gap = g;
    prev_t = sim.time;
  }
  for (int k = 0; k < 10; ++k) sim.step();  // clear of the floor: free flight
  const std::size_t g = grain(sim);
  return {sim.p.v[g].y() / v0, t_out - t_in, sim.p.x[g].x(), sim.p.v[g].x()};
}

}  // namespace

// (a) The grain bounces off the smooth floor exactly as off a wall particle
// right beneath it, and both as the damped linear oscillator of Eq. (2) with
// the wall held on its course: m x'' = -Y x - gamma_N m_eff x', so
// omega_0^2 = Y / m, beta = gamma_N m_eff / (2 m), t_c = pi / sqrt(omega_0^2 - beta^2),
// e = exp(-beta t_c), with m_eff of Eq. (5) from the wall particle's mass.
TEST(FlatBoxWalls, DropOnTheFloorIsTheWallParticleCollision) {
  omp_set_num_threads(1);
  using F = Floors<Gear5>;
  const double r = 1.0, v0 = 50.0, dt = 2e-6, x0 = 3.7;
  const double m = disk_mass(r), m_w = disk_mass(kRw);
  for (double wall_inv_mass : {1.0 / m_w, 0.0}) {
    const ShakerMotion<2> still = shaker(0.0, 3.0, 0.0);
    F::Flat flat;
    set_up(flat, dt, 0.0);
    F::flat(flat, still, wall_inv_mass);
    add_disk(flat.p, {x0, r + 0.3 * v0 * dt}, {0, -v0}, r);
    flat.init();
    F::Particle part;
    set_up(part, dt, 0.0);
    F::particle(part, still, wall_inv_mass, x0);
    add_disk(part.p, {x0, r + 0.3 * v0 * dt}, {0, -v0}, r);
    part.init();
    const Bounce a = bounce(flat, r, v0), b = bounce(part, r, v0);

    const double m_eff = 1.0 / (1.0 / m + wall_inv_mass);
    const double beta = 0.5 * kGammaN * m_eff / m, w = std::sqrt(kY / m - beta * beta);
    const double tc = M_PI / w, e = std::exp(-beta * tc);
    std::printf("1/m_w = %g: smooth e = %.6f t_c = %.6e, wall particle e = %.6f t_c = %.6e, analytic %.6f %.6e\n",
                wall_inv_mass, a.restitution, a.contact_time, b.restitution, b.contact_time, e, tc);
    EXPECT_NEAR(a.restitution, b.restitution, 1e-9);
    EXPECT_NEAR(a.contact_time, b.contact_time, 1e-9);
    EXPECT_NEAR(a.restitution, e, 2e-4);
    EXPECT_NEAR(a.contact_time, tc, 1e-3 * tc);
    // straight up again: a flat floor gives no sideways push
    EXPECT_EQ(a.x, x0);
    EXPECT_EQ(a.vx, 0.0);
  }
}

namespace {

struct Ride {
  double worst_dv, worst_df, worst_dov;  // over the samples at full amplitude
  double peak_speed, weight, sink;       // scales: A 2 pi f, m g, m g / Y
  double final_y, final_vy;
};

// A grain resting on the floor of a box shaken gently (Gamma = A w^2 / g = 0.18
// at A = 0.5 cm, 3 Hz): it rides the floor, so its velocity is the shaker's,
// the floor pushes it with m (g + d^2 y_box / dt^2), and with no relative
// velocity (no damping) Eq. (2) holds it at the overlap m (g + d^2 y_box / dt^2) / Y.
template <class Sim>
Ride ride(Sim& sim, const ShakerMotion<2>& m, double r, double dt) {
  const double mass = disk_mass(r), f = m.f0;
  Ride out{0, 0, 0, m.amplitude * 2 * M_PI * f, mass * kG, mass * kG / kY, 0, 0};
  const long steps = std::lround((m.start + 6.0 / f) / dt);
  for (long k = 0; k < steps; ++k) {
    sim.step();
    if (sim.time < m.start + 3.0 / f) continue;  // full amplitude from cycle 2, and a cycle to forget the jolt
    const std::size_t g = grain(sim);
    const double h = 1e-6, a_box = (m.vy(sim.time + h) - m.vy(sim.time - h)) / (2 * h);
    out.worst_dv = std::max(out.worst_dv, std::abs(sim.p.v[g].y() - m.vy(sim.time)));
    out.worst_df = std::max(out.worst_df, std::abs(sim.p.f[g].y() - mass * (kG + a_box)));
    const double overlap = r - (sim.p.x[g].y() - m.y(sim.time));
    out.worst_dov = std::max(out.worst_dov, std::abs(overlap - mass * (kG + a_box) / kY));
  }
  const std::size_t g = grain(sim);
  out.final_y = sim.p.x[g].y() - m.y(sim.time);
  out.final_vy = sim.p.v[g].y();
  return out;
}

template <template <int, class> class Integrator>
void expect_rides_the_floor() {
  using F = Floors<Integrator>;
  const double r = 1.0, dt = 5e-5, x0 = -2.0;
  const ShakerMotion<2> m = shaker(0.5, 3.0, 0.05);
  const double sink = disk_mass(r) * kG / kY;  // static overlap
  typename F::Flat flat;
  set_up(flat, dt, kG);
  F::flat(flat, m, 0.0);
  add_disk(flat.p, {x0, r - sink}, {0, 0}, r);
  flat.init();
  typename F::Particle part;
  set_up(part, dt, kG);
  F::particle(part, m, 0.0, x0);
  add_disk(part.p, {x0, r - sink}, {0, 0}, r);
  part.init();
  const Ride a = ride(flat, m, r, dt), b = ride(part, m, r, dt);
  std::printf(
      "smooth floor: |v - v_box| <= %.3e of %.3g cm/s, |f - m(g + a_box)| <= %.3e of mg = %.4g, "
      "overlap off by <= %.3e of mg/Y = %.3e\n",
      a.worst_dv, a.peak_speed, a.worst_df, a.weight, a.worst_dov, a.sink);
  EXPECT_LT(a.worst_dv, 0.01 * a.peak_speed);
  EXPECT_LT(a.worst_df, 0.02 * a.weight);
  EXPECT_LT(a.worst_dov, 0.02 * a.sink);
  // and it sits where a wall particle beneath would hold it, moving as fast
  EXPECT_NEAR(a.final_y, b.final_y, 1e-9);
  EXPECT_NEAR(a.final_vy, b.final_vy, 1e-6);
  EXPECT_NEAR(a.worst_df, b.worst_df, 1e-6 * a.weight);
}

}  // namespace

// (b) The floor's velocity enters the damping and its position is taken at
// the positions' time: a floor at rest in the damping term would hold the
// grain at an overlap off by gamma_N m A 2 pi f / Y (~ m g / Y here), one a
// step out of phase by A 2 pi f dt (~ m g / (4 Y)).
TEST(FlatBoxWalls, GrainRidesAGentlyShakenFloorGear) {
  omp_set_num_threads(1);
  expect_rides_the_floor<Gear5>();
}

TEST(FlatBoxWalls, GrainRidesAGentlyShakenFloorLeapfrog) {
  omp_set_num_threads(1);
  expect_rides_the_floor<Leapfrog>();
}

namespace {

// One grain against the walls at time t: the force and torque they apply.
struct Felt {
  Eigen::Vector2d f;
  double torque;
};

Felt feel(const FlatBoxWalls& w, Eigen::Vector2d x, Eigen::Vector2d v, double spin, double t) {
  ParticleStore<2> p;
  add_disk(p, x, v, 1.0, 0, spin);
  Law law;
  law.young = kY;
  law.gamma_n = kGammaN;
  law.gamma_s = kGammaS;
  law.mu = kMu;
  w.apply(p, law, 0, 1, t);
  return {p.f[0], p.tq[0][0]};
}

FlatBoxWalls moving_walls() {
  FlatBoxWalls w;
  w.half_width = kHalfWidth;
  w.wall_radius = kRw;
  w.wall_inv_mass = 1.0 / disk_mass(kRw);
  w.side_top = 30.0;
  w.shaker = shaker(2.0, 3.0, 0.0);
  return w;
}

}  // namespace

// (c) A grain pressed against a side wall by an overlap delta: Eq. (2) gives
// F^N = Y delta along x; Eq. (3) the tangential force -gamma_S m_eff v_rel while
// that is below mu |F^N|, and mu |F^N| against the sliding beyond; Eq. (6) the
// torque R F^S about the grain. The wall moves with the shaker, so "at rest"
// means at the wall's velocity.
TEST(FlatBoxWalls, SideWallPushesAlongXAndCapsTheSlidingForce) {
  const FlatBoxWalls w = moving_walls();
  const double t = 0.37, vw = w.shaker.vy(t), yb = w.shaker.y(t), r = 1.0, delta = 1e-3;
  ASSERT_GT(std::abs(vw), 5.0);  // the wall is moving
  const double m = disk_mass(r), m_eff = 1.0 / (1.0 / m + w.wall_inv_mass), fn = kY * delta;
  for (double side : {+1.0, -1.0}) {
    const Eigen::Vector2d x(side * (kHalfWidth - r + delta), yb + 12.0);
    // not sliding: only the normal force, inwards
    Felt c = feel(w, x, {0, vw}, 0.0, t);
    EXPECT_NEAR(c.f.x(), -side * fn, 1e-9 * fn);
    EXPECT_NEAR(c.f.y(), 0.0, 1e-9 * fn);
    EXPECT_NEAR(c.torque, 0.0, 1e-9 * fn);
    // rolling along the wall: the contact point is at rest on it, no friction.
    // Contact point x + side R x^: its velocity v + w R side y^.
    const double spin = 4.0;
    c = feel(w, x, {0, vw - side * spin * r}, spin, t);
    EXPECT_NEAR(c.f.y(), 0.0, 1e-9 * fn);
    EXPECT_NEAR(c.f.x(), -side * fn, 1e-9 * fn);
    for (double u : {10.0, -10.0, 1000.0, -1000.0}) {  // sliding up or down relative to the wall
      c = feel(w, x, {0, vw + u}, 0.0, t);
      const double viscous = kGammaS * m_eff * std::abs(u);
      const double expected = -std::copysign(std::min(viscous, kMu * fn), u);
      EXPECT_NEAR(c.f.x(), -side * fn, 1e-9 * fn) << u;
      EXPECT_NEAR(c.f.y(), expected, 1e-9 * fn) << u;
      EXPECT_NEAR(c.torque, side * r * c.f.y(), 1e-9 * fn) << u;  // (R side x^) x f
      if (std::abs(u) > 100)
        EXPECT_NEAR(std::abs(c.f.y()), kMu * std::abs(c.f.x()), 1e-9 * fn) << "capped";
      else
        EXPECT_LT(std::abs(c.f.y()), kMu * fn) << "viscous";
    }
  }
  // the floor likewise, along +y
  const Felt c = feel(w, {5.0, yb + r - delta}, {0, vw}, 0.0, t);
  EXPECT_NEAR(c.f.y(), fn, 1e-9 * fn);
  EXPECT_NEAR(c.f.x(), 0.0, 1e-9 * fn);
}

// The surfaces are where the particle walls' are: floor y = y_box(t), side
// walls x = +-W/2, just touching means no force; the side walls end in the
// top wall particle's half disk.
TEST(FlatBoxWalls, SurfacesAndTop) {
  const FlatBoxWalls w = moving_walls();
  const double t = 0.9, yb = w.shaker.y(t), vw = w.shaker.vy(t), r = 1.0, eps = 1e-9;
  EXPECT_EQ(feel(w, {0.0, yb + r + eps}, {0, vw}, 0.0, t).f.norm(), 0.0);
  EXPECT_GT(feel(w, {0.0, yb + r - eps}, {0, vw}, 0.0, t).f.y(), 0.0);
  EXPECT_EQ(feel(w, {kHalfWidth - r - eps, yb + 5}, {0, vw}, 0.0, t).f.norm(), 0.0);
  EXPECT_LT(feel(w, {kHalfWidth - r + eps, yb + 5}, {0, vw}, 0.0, t).f.x(), 0.0);
  EXPECT_EQ(feel(w, {-kHalfWidth + r + eps, yb + 5}, {0, vw}, 0.0, t).f.norm(), 0.0);
  EXPECT_GT(feel(w, {-kHalfWidth + r - eps, yb + 5}, {0, vw}, 0.0, t).f.x(), 0.0);
  // above the right wall's top centre: pushed away from it by the cap, as by
  // the top wall particle
  const double top = yb + w.side_top, delta = 1e-3, angle = 80.0 * M_PI / 180.0, reach = r + kRw - delta;
  const Eigen::Vector2d n(-std::cos(angle), std::sin(angle));  // from the top centre, into the box
  const Felt c = feel(w, Eigen::Vector2d(kHalfWidth + kRw, top) + reach * n, {0, vw}, 0.0, t);
  EXPECT_NEAR(c.f.x(), kY * delta * n.x(), 1e-9 * kY * delta);
  EXPECT_NEAR(c.f.y(), kY * delta * n.y(), 1e-9 * kY * delta);
  // well above it: nothing
  EXPECT_EQ(feel(w, {kHalfWidth - r + 0.5, top + kRw + r + 0.1}, {0, vw}, 0.0, t).f.norm(), 0.0);
}

// A scene with box.walls = "smooth" builds flat walls where its particle walls
// would be: same surfaces, same height, same wall mass; and no wall particles.
TEST(FlatBoxWalls, SceneBuildsThemWhereTheParticleWallsAre) {
  const char* src = std::getenv("GRANULAR_SOURCE_DIR");
  const auto path = (std::filesystem::path(src ? src : ".") / "scenes/box/f3.0_big.toml").string();
  const std::vector<std::string> small = {"particles.count=100", "box.width=20", "box.wall_height=30",
                                          "integrator.kind=\"gear\""};
  auto sets = small;
  SceneFile fp(path, sets);
  const BoxScene sp = read_box_scene(fp);
  sets.push_back("box.walls=\"smooth\"");
  SceneFile fs(path, sets);
  const BoxScene ss = read_box_scene(fs);
  ASSERT_FALSE(sp.smooth_walls);
  ASSERT_TRUE(ss.smooth_walls);
  BoxSim particle_v = make_box(sp), smooth_v = make_box(ss);
  const auto& part = std::get<ParticleWallBoxOf<PoeschelHerrmannLaw<2>, Gear5>>(particle_v);
  const auto& smooth = std::get<SmoothBoxOf<PoeschelHerrmannLaw<2>, Gear5>>(smooth_v);
  const FlatBoxWalls& w = std::get<FlatBoxWalls>(smooth.walls);
  double floor_y = INFINITY, side_x = 0, top = -INFINITY, inv_m = -1;
  for (std::size_t i = 0; i < part.p.size(); ++i) {
    if (part.p.species[i] != kWallSpecies) continue;
    const auto& a = part.integrator.motion.anchor[static_cast<std::size_t>(part.p.id[i])];
    floor_y = std::min(floor_y, a.y());
    side_x = std::max(side_x, a.x());
    top = std::max(top, a.y());
    inv_m = part.p.inv_m[i];
    EXPECT_EQ(0.5 * part.p.d[i], w.wall_radius);
  }
  EXPECT_EQ(floor_y + w.wall_radius, 0.0);            // floor surface at y = 0
  EXPECT_EQ(side_x - w.wall_radius, 0.5 * ss.width);  // side surfaces at x = +-W/2
  EXPECT_EQ(w.half_width, 0.5 * ss.width);
  EXPECT_EQ(w.side_top, top);  // the same height
  EXPECT_EQ(w.wall_inv_mass, inv_m);
  for (auto s : smooth.p.species) EXPECT_NE(s, kWallSpecies);
  EXPECT_EQ(smooth.p.size() + part.integrator.motion.anchor.size(), part.p.size());
  // the same shaker
  for (double t : {0.5, 1.3, 2.2}) EXPECT_EQ(w.shaker.y(t), part.integrator.motion.y(t));
}

// The shaker's velocity is the derivative of its position through the
// start-up envelope and a frequency ramp (the walls' velocity in Eq. (2)).
TEST(FlatBoxWalls, ShakerVelocityIsTheDerivativeDuringARamp) {
  ShakerMotion<2> m;
  m.amplitude = 2.0;
  m.f0 = 2.0;
  m.f1 = 4.0;
  m.start = 1.0;
  m.ramp_start = 0.3;
  m.ramp_time = 5.0;
  m.startup_cycles = 2.0;
  for (double t : {1.1, 1.25, 1.6, 2.0, 3.4, 6.0, 6.5, 8.0}) {
    const double h = 1e-6;
    EXPECT_NEAR(m.vy(t), (m.y(t + h) - m.y(t - h)) / (2 * h), 1e-5) << t;
  }
}

#include "engine/coulomb_census.hpp"

// The Coulomb census (engine/coulomb_census.hpp) counts a grain on a smooth
// wall as the pair with the wall particle it stands for, as it counts a grain
// on a wall of particles.
TEST(FlatBoxWalls, CensusCountsThemAsGrainWallParticlePairs) {
  omp_set_num_threads(1);
  const char* src = std::getenv("GRANULAR_SOURCE_DIR");
  const auto path = (std::filesystem::path(src ? src : ".") / "scenes/box/f3.0_big.toml").string();
  for (const char* walls : {"box.walls=particles", "box.walls=smooth"}) {
    SceneFile f(path, {"particles.count=60", "box.width=20", "box.wall_height=30", "big.enabled=false", walls});
    const BoxScene s = read_box_scene(f);
    BoxSim sim = make_box(s);
    std::visit(
        [&](auto& v) {
          for (int k = 0; k < 6000; ++k) v.step();  // 0.3 s: settled on the floor
          const CoulombCensus c = coulomb_census(v);
          const int S = c.species;
          const double grain_wall = c.pair_contacts[0 * S + kWallSpecies];
          std::printf("%s: %g grain-wall contacts, %g at the cap\n", walls, grain_wall,
                      c.pair_at_cap[0 * S + kWallSpecies]);
          EXPECT_GE(grain_wall, 8.0) << walls;  // at least the bottom row (8 per row at this width)
          EXPECT_LE(c.pair_at_cap[0 * S + kWallSpecies], grain_wall);
          for (double n : c.wall_contacts) EXPECT_EQ(n, 0.0);
        },
        sim);
  }
}
