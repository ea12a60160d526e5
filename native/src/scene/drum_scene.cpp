#include "scene/drum_scene.hpp"

#include "scene/law_mapping.hpp"
#include "contact/laws.hpp"
#include "scene/law_mapping.hpp"
#include "scene/step_rule.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <sstream>

namespace granular {

double DrumScene::rotation_period() const { return 2.0 * M_PI / omega; }

long DrumScene::steps_per(double rot) const { return std::lround(rot * rotation_period() / dt); }

std::vector<long> DrumScene::final_snapshot_steps() const {
  std::vector<long> steps;
  for (long k = final_snapshots - 1; k >= 1; --k) steps.push_back(steps_per(rotations - k * final_snapshot_every));
  return steps;
}

namespace {

// Only the required keys: reading it lists every key a drum scene has.
constexpr const char* kMinimalDrum = R"(
[scene]
kind = "drum"
name = "minimal"
[drum]
length = 32.0
diameter = 16.0
omega = 0.5
ends = "periodic"
[particles]
fill_density = 0.3
big_diameter = 1.3
initial_state = "mixed"
[friction]
gamma_s_bb = 1.0
gamma_s_ss = 1.0
gamma_s_bw = 1.0
gamma_s_sw = 1.0
[run]
rotations = 1.0
)";

// The initial lattice must hold the particles without overlap, inside the
// wall, in a drum that has room for them (see drum_particles).
void check_fits(const SceneFile& f, const DrumScene& s) {
  const double d_max = std::max(s.small_diameter, s.big_diameter);
  const std::string d_key = s.big_diameter >= s.small_diameter ? "particles.big_diameter" : "particles.small_diameter";
  // Nearest fcc sites are a/sqrt(2) apart, a = (4/rho)^(1/3), or more once the
  // lattice is stretched to the drum. Mixed: any site may hold either species;
  // segregated: each region has the small spheres' volume fraction.
  const double need = s.initial_state == "mixed" ? d_max : s.small_diameter;
  const double spacing = std::cbrt(4.0 / s.fill_density) / std::sqrt(2.0);
  if (spacing < need)
    f.fail("particles.fill_density",
           "cannot be packed: at " + number_text(s.fill_density) + " particles per unit volume the lattice sites are " +
               number_text(spacing) + " apart, less than the particle diameter " + number_text(need) + " (" +
               (need == d_max ? d_key : std::string("particles.small_diameter")) + ", " +
               f.origin(need == d_max ? d_key : "particles.small_diameter") + "); at most " +
               number_text(std::sqrt(2.0) / (need * need * need)) + " for these particles");
  if (s.fill_margin >= 0.5 * s.diameter && f.origin("particles.fill_margin") != "default")
    f.fail("particles.fill_margin", "leaves no room inside the drum (drum.diameter = " + number_text(s.diameter) + ", " +
                                        f.origin("drum.diameter") + ")");
  if (0.5 * s.diameter - s.fill_margin < 0.5 * d_max)
    f.fail("drum.diameter", "too small for its particles: " + number_text(s.diameter) + " leaves no room for a diameter " +
                                number_text(d_max) + " inside particles.fill_margin = " + number_text(s.fill_margin) + " (" +
                                f.origin("particles.fill_margin") + ") of the wall");
  if (s.fill_margin < 0.5 * d_max)
    f.fail("particles.fill_margin", number_text(s.fill_margin) + " lets particles of diameter " + number_text(d_max) +
                                        " start through the drum wall; it must be at least half the largest "
                                        "diameter (" + number_text(0.5 * d_max) + ")");
  const double reach = 2.0 * (std::pow(2.0, 1.0 / 6.0) * d_max + s.skin);
  if (!s.capped && s.length < reach)
    f.fail("drum.length", "a periodic drum must be at least twice the interaction range plus the neighbour skin "
                          "long (" + number_text(reach) + "), got " + number_text(s.length));
  const std::size_t n = drum_particles(s).size();
  if (n < 2)
    f.fail(s.capped && s.length < s.diameter ? "drum.length" : "drum.diameter",
           "too small for its particles: the initial lattice (fill density " + number_text(s.fill_density) +
               ") places " + std::to_string(n) + " particle(s) in a drum of diameter " + number_text(s.diameter) +
               " and length " + number_text(s.length));
}

DrumScene read_fields(SceneFile& f) {
  DrumScene s;
  f.choice("scene.kind", {"drum"});
  s.name = f.text("scene.name");
  s.description = f.text("scene.description", "");

  s.length = f.positive("drum.length", f.number("drum.length"));
  s.diameter = f.positive("drum.diameter", f.number("drum.diameter"));
  s.omega = f.number("drum.omega");
  if (s.omega == 0.0) f.fail("drum.omega", "must be non-zero (run lengths are counted in rotations)");
  s.capped = f.choice("drum.ends", {"periodic", "capped"}) == "capped";
  s.wall_diameter = f.positive("drum.wall_diameter", f.number("drum.wall_diameter", 1.0));
  s.wall_lever = f.choice("drum.wall_spin_lever", {"paper", "pair"}, "paper");

  s.fill_density = f.positive("particles.fill_density", f.number("particles.fill_density"));
  s.small_diameter = f.positive("particles.small_diameter", f.number("particles.small_diameter", 1.0));
  s.big_diameter = f.positive("particles.big_diameter", f.number("particles.big_diameter"));
  s.diameter_spread = f.non_negative("particles.diameter_spread", f.number("particles.diameter_spread", 0.2));
  if (s.diameter_spread >= std::min(s.small_diameter, s.big_diameter))
    f.fail("particles.diameter_spread", "must be smaller than both nominal diameters");
  s.fill_margin = f.non_negative("particles.fill_margin", f.number("particles.fill_margin", 1.0));
  s.initial_speed = f.non_negative("particles.initial_speed", f.number("particles.initial_speed", 1.0));
  s.initial_state = f.choice("particles.initial_state", {"mixed", "segregated_band", "segregated_halves"});
  const long seed = f.integer("particles.seed", 1);
  if (seed < 0) f.fail("particles.seed", "must be >= 0");
  s.seed = static_cast<std::uint64_t>(seed);
  s.rotation = f.flag("particles.rotation", true);

  s.law = f.choice("contact.law", law_names(RapaportSceneLaws<MappingInputs>{}), "rapaport");  // contact/laws.hpp
  s.impact_speed = f.positive("contact.impact_speed", f.number("contact.impact_speed", 1.0));
  s.gamma_n = f.non_negative("contact.gamma_n", f.number("contact.gamma_n", 5.0));
  s.kappa = f.positive("contact.kappa", f.number("contact.kappa", 0.2));
  s.mu_max = f.non_negative("contact.mu_max", f.number("contact.mu_max", 0.5));
  s.gamma_s_bb = f.non_negative("friction.gamma_s_bb", f.number("friction.gamma_s_bb"));
  s.gamma_s_ss = f.non_negative("friction.gamma_s_ss", f.number("friction.gamma_s_ss"));
  s.gamma_s_bw = f.non_negative("friction.gamma_s_bw", f.number("friction.gamma_s_bw"));
  s.gamma_s_sw = f.non_negative("friction.gamma_s_sw", f.number("friction.gamma_s_sw"));
  s.gravity = f.non_negative("gravity.g", f.number("gravity.g", 5.0));

  s.integrator = f.choice("integrator.kind", {"leapfrog"}, "leapfrog");
  // Default step: 0.01, twice the paper's 0.005, the cheapest step that keeps the
  // slope, the band count and the band formation time within their tolerances
  // (docs/speed_accuracy.md, "Defaults"), or shorter where the scene's fastest
  // impact needs it (scene/step_rule.hpp); the paper's step is --set integrator.dt=0.005.
  s.dt = f.positive("integrator.dt", f.number("integrator.dt", drum_step_rule(s).dt));
  s.skin = f.positive("neighbor.skin", f.number("neighbor.skin", 0.4));

  s.rotations = f.positive("run.rotations", f.number("run.rotations"));
  s.snapshot_every = f.positive("run.snapshot_every", f.number("run.snapshot_every", 10.0));
  s.profile_every = f.positive("run.profile_every", f.number("run.profile_every", 0.5));
  s.profile_slice_width = f.positive("run.profile_slice_width", f.number("run.profile_slice_width", 1.0));
  if (s.profile_slice_width > s.length) f.fail("run.profile_slice_width", "is wider than the drum");
  s.final_snapshots = f.integer("run.final_snapshots", 0);
  if (s.final_snapshots < 0) f.fail("run.final_snapshots", "must be 0 or more");
  s.final_snapshot_every = f.positive("run.final_snapshot_every", f.number("run.final_snapshot_every", 5.0));
  if (s.final_snapshots > 1 && (s.final_snapshots - 1) * s.final_snapshot_every >= s.rotations)
    f.fail("run.final_snapshots", std::to_string(s.final_snapshots) + " snapshots " +
                                      number_text(s.final_snapshot_every) +
                                      " rotations apart reach back to the run's start (run.rotations " +
                                      number_text(s.rotations) + ")");

  s.paper_n = f.integer("paper.N", 0);
  s.paper_rotations = f.number("paper.rotations", 0.0);
  s.paper_bands = f.text("paper.bands", "");
  f.text("paper.figure", "");
  f.text("paper.note", "");

  // Limits (scene_file.hpp): the fill lattice (constant (4/rho)^(1/3)) and the
  // run must stay countable before anything is built.
  const double lattice = std::cbrt(4.0 / s.fill_density);
  const double estimate = s.fill_density * 0.25 * M_PI * s.diameter * s.diameter * s.length;
  if (estimate > kMaxParticles)
    f.fail("drum.length", "the drum would hold about " + number_text(estimate) + " particles (drum.diameter " +
                              number_text(s.diameter) + ", particles.fill_density " + number_text(s.fill_density) +
                              "), more than one run can (" + number_text(kMaxParticles) + ")");
  if (s.diameter / lattice > 1e6 || s.length / lattice > 1e7)
    f.fail("particles.fill_density", "too sparse for the drum's size: the fill lattice would have more than 1e6 "
                                     "cells across or 1e7 along it");
  if (s.rotations * s.rotation_period() / s.dt > kMaxSteps)
    f.fail("run.rotations", "would take " + number_text(s.rotations * s.rotation_period() / s.dt) +
                                " steps (integrator.dt " + number_text(s.dt) + "), more than " + number_text(kMaxSteps));
  if (s.steps_per(s.rotations) < 1)
    f.fail("run.rotations", number_text(s.rotations) + " rotation(s) at drum.omega = " + number_text(s.omega) + " (" +
                                f.origin("drum.omega") + ") last " + number_text(s.rotations * s.rotation_period()) +
                                " time units, which round to 0 steps of integrator.dt " + number_text(s.dt) +
                                ": nothing would be simulated");
  check_fits(f, s);  // builds the particles
  check_law_settable(f, s.law, mapping_inputs(s));
  return s;
}

}  // namespace

DrumScene read_drum_scene(SceneFile& f) {
  static const auto known = SceneFile::keys_read_by(read_fields, kMinimalDrum, "<built-in drum scene>");
  return f.read_checked(read_fields, known);
}

namespace {

// Reproducible uniform doubles in [0, 1) from a 64-bit Mersenne twister.
struct Uniform {
  std::mt19937_64 gen;
  explicit Uniform(std::uint64_t seed) : gen(seed) {}
  double operator()() { return static_cast<double>(gen() >> 11) * 0x1.0p-53; }
};

// fcc sites in the drum section y in [y0, y1] (see drum_scene.hpp), y wrapped
// into [-L/2, L/2) when the drum is periodic.
void fill_region(const DrumScene& s, double rho, double y0, double y1, bool margin_lo, bool margin_hi,
                 std::vector<Eigen::Vector3d>& out) {
  static const double basis[4][3] = {{0, 0, 0}, {0.5, 0.5, 0}, {0.5, 0, 0.5}, {0, 0.5, 0.5}};
  const double a = std::cbrt(4.0 / rho);
  const int nx = std::max(1, static_cast<int>(s.diameter / a));
  const int ny = std::max(1, static_cast<int>((y1 - y0) / a));
  const double ax = s.diameter / nx, ay = (y1 - y0) / ny;
  const double rmax = 0.5 * s.diameter - s.fill_margin;
  for (int j = 0; j < ny; ++j)
    for (int k = 0; k < nx; ++k)
      for (int i = 0; i < nx; ++i)
        for (const auto& b : basis) {
          const double x = (i + b[0] + 0.25) * ax - 0.5 * s.diameter;
          const double z = (k + b[2] + 0.25) * ax - 0.5 * s.diameter;
          double y = y0 + (j + b[1] + 0.25) * ay;
          if (std::hypot(x, z) >= rmax) continue;
          if (margin_lo && y - y0 <= s.fill_margin) continue;
          if (margin_hi && y1 - y <= s.fill_margin) continue;
          if (!s.capped && y >= 0.5 * s.length) y -= s.length;
          out.emplace_back(x, y, z);
        }
}

}  // namespace

ParticleStore<3> drum_particles(const DrumScene& s) {
  const double half = 0.5 * s.length;
  // Segregated regions are filled with the same solid volume fraction: the big
  // region at number density rho (d_small/d_big)^3. This reproduces Table I's N
  // for runs V, W, X, Y (docs/drum_scenes.md).
  const double rho_big = s.fill_density * std::pow(s.small_diameter / s.big_diameter, 3);
  std::vector<Eigen::Vector3d> sites_small, sites_big, sites;
  std::vector<int> species;
  if (s.initial_state == "mixed") {
    fill_region(s, s.fill_density, -half, half, s.capped, s.capped, sites);
  } else if (s.initial_state == "segregated_band") {
    // Small particles in the central band |y| < L/4, big ones elsewhere (#V, #W).
    fill_region(s, s.fill_density, -0.5 * half, 0.5 * half, true, true, sites_small);
    fill_region(s, rho_big, 0.5 * half, 1.5 * half, true, true, sites_big);
    if (s.capped) {  // a band between caps: the big region is two pieces
      sites_big.clear();
      fill_region(s, rho_big, -half, -0.5 * half, true, true, sites_big);
      fill_region(s, rho_big, 0.5 * half, half, true, true, sites_big);
    }
  } else {  // segregated_halves: small in y < 0, big in y > 0 (#X, #Y)
    fill_region(s, s.fill_density, -half, 0.0, true, true, sites_small);
    fill_region(s, rho_big, 0.0, half, true, true, sites_big);
  }

  Uniform rnd(s.seed);
  if (s.initial_state == "mixed") {
    // Equal numbers of each species, assigned at random (Sec. IV).
    if (sites.size() % 2 == 1) sites.erase(sites.begin() + static_cast<long>(rnd() * sites.size()));
    std::vector<std::size_t> order(sites.size());
    std::iota(order.begin(), order.end(), 0);
    for (std::size_t k = order.size(); k > 1; --k) std::swap(order[k - 1], order[static_cast<std::size_t>(rnd() * k)]);
    species.assign(sites.size(), 0);
    for (std::size_t k = 0; k < order.size() / 2; ++k) species[order[k]] = 1;
  } else {
    sites = sites_small;
    sites.insert(sites.end(), sites_big.begin(), sites_big.end());
    species.assign(sites_small.size(), 0);
    species.insert(species.end(), sites_big.size(), 1);
  }

  ParticleStore<3> p;
  for (std::size_t k = 0; k < sites.size(); ++k) {
    const double nominal = species[k] == 1 ? s.big_diameter : s.small_diameter;
    const double d = nominal - s.diameter_spread * rnd();  // uniform in [d - 0.2, d] (Sec. IV)
    const double m = d * d * d;                            // m_i = d_i^3 (Sec. III)
    const double inertia = 0.5 * s.kappa * m * d * d;      // I = kappa m d^2 / 2 (see rapaport.hpp)
    // Random direction, fixed speed.
    const double cz = 2.0 * rnd() - 1.0, phi = 2.0 * M_PI * rnd(), sz = std::sqrt(1.0 - cz * cz);
    const Eigen::Vector3d v = s.initial_speed * Eigen::Vector3d(sz * std::cos(phi), sz * std::sin(phi), cz);
    p.add(sites[k], v, Eigen::Vector3d::Zero(), d, m, inertia, species[k]);
  }
  return p;
}

}  // namespace granular
