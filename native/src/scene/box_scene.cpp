#include "scene/box_scene.hpp"

#include <cmath>
#include <random>
#include <sstream>

#include "contact/laws.hpp"
#include "integrate/motion.hpp"
#include "scene/step_rule.hpp"

namespace granular {

double BoxScene::mass(double r) const { return (mass_area ? 1.0 : 2.0) * M_PI * r * r * density; }

namespace {

// Only the required keys: reading it lists every key a shaken-box scene has.
constexpr const char* kMinimalBox = R"(
[scene]
kind = "shaken_box"
name = "minimal"
[shaking]
frequency = 3.0
[run]
duration = 1.0
)";

BoxScene read_fields(SceneFile& f) {
  BoxScene s;
  f.choice("scene.kind", {"shaken_box"});
  s.name = f.text("scene.name");
  s.description = f.text("scene.description", "");

  s.width = f.positive("box.width", f.number("box.width", 60.0));
  s.wall_height = f.positive("box.wall_height", f.number("box.wall_height", 100.0));
  s.wall_radius = f.positive("box.wall_radius", f.number("box.wall_radius", 1.0));
  s.wall_spacing = f.positive("box.wall_spacing", f.number("box.wall_spacing", 2.0));
  s.wall_infinite_mass = f.choice("box.wall_mass", {"particle", "infinite"}, "particle") == "infinite";
  s.smooth_walls = f.choice("box.walls", {"particles", "smooth"}, "particles") == "smooth";

  s.amplitude = f.non_negative("shaking.amplitude", f.number("shaking.amplitude", 2.0));
  s.frequency = f.positive("shaking.frequency", f.number("shaking.frequency"));
  s.ramp_to = f.positive("shaking.ramp_to", f.number("shaking.ramp_to", s.frequency));
  s.ramp_start = f.non_negative("shaking.ramp_start", f.number("shaking.ramp_start", 0.0));
  s.ramp_time = f.non_negative("shaking.ramp_time", f.number("shaking.ramp_time", 0.0));
  s.startup_cycles = f.non_negative("shaking.startup_cycles", f.number("shaking.startup_cycles", 2.0));
  if (s.ramp_to != s.frequency && s.ramp_time == 0.0)
    f.fail("shaking.ramp_time", "must be > 0 when shaking.ramp_to (" + f.origin("shaking.ramp_to") +
                                    ") differs from shaking.frequency");

  s.count = f.integer("particles.count", 950);
  if (s.count < 1) f.fail("particles.count", "must be >= 1");
  s.radius_min = f.positive("particles.radius_min", f.number("particles.radius_min", 0.85));
  s.radius_max = f.positive("particles.radius_max", f.number("particles.radius_max", 1.15));
  if (s.radius_max < s.radius_min)
    f.fail("particles.radius_max", "must be >= particles.radius_min (" + number_text(s.radius_min) + ", " +
                                       f.origin("particles.radius_min") + "), got " + number_text(s.radius_max));
  s.density = f.positive("particles.density", f.number("particles.density", 1.0));
  s.mass_area = f.choice("particles.mass_rule", {"paper", "area"}, "paper") == "area";
  // I = inertia_factor m R^2 for the grains and the big disk; 1/2 is a uniform disk.
  s.inertia_factor = f.positive("particles.inertia_factor", f.number("particles.inertia_factor", 0.5));
  const long seed = f.integer("particles.seed", 1);
  if (seed < 0) f.fail("particles.seed", "must be >= 0");
  s.seed = static_cast<std::uint64_t>(seed);
  s.rotation = f.flag("particles.rotation", true);

  s.big = f.flag("big.enabled", true);
  s.big_radius = f.positive("big.radius", f.number("big.radius", 4.0));
  s.big_gap = f.non_negative("big.gap", f.number("big.gap", 2.0));

  s.law = f.choice("contact.law", law_names(BoxSceneLaws<BoxScene>{}), "poeschel_herrmann");  // contact/laws.hpp
  const bool viscel = s.law == "viscel";
  s.young = f.positive("contact.young", f.number("contact.young", 3e6));
  s.gamma_n = f.non_negative("contact.gamma_n", f.number("contact.gamma_n", 100.0));
  s.gamma_s = f.non_negative("contact.gamma_s", f.number("contact.gamma_s", 1.0));
  s.mu = f.non_negative("contact.mu", f.number("contact.mu", 0.5));
  s.damping = f.choice("contact.damping", {"normal", "literal"}, "normal") == "literal" ? Damping::literal
                                                                                        : Damping::normal;
  if (!with_law(BoxSceneLaws<BoxScene>{}, s.law, s.damping, [](auto) {}))
    f.fail("contact.damping", "\"literal\" is a reading of Poeschel & Herrmann's Eq. (2); contact.law = \"" + s.law +
                                  "\" (" + f.origin("contact.law") + ") damps the normal component only");
  // YADE's harmonic mixing takes a zero coefficient as absent, so a zero gamma
  // cannot be represented per material (contact/viscel.hpp).
  if (viscel && s.gamma_n <= 0)
    f.fail("contact.gamma_n", "must be > 0 with contact.law = \"viscel\" (" + f.origin("contact.law") + ")");
  if (viscel && s.gamma_s <= 0)
    f.fail("contact.gamma_s", "must be > 0 with contact.law = \"viscel\" (" + f.origin("contact.law") + ")");
  s.gravity = f.non_negative("gravity.g", f.number("gravity.g", 981.0));

  // Default: the leapfrog (integrate/leapfrog.hpp) at 2e-4 s, the cheapest setting that keeps the
  // convection, the bed, the big disk's rise and the onset frequency within
  // their tolerances (docs/speed_accuracy.md, "Defaults"), or shorter where the
  // scene's contacts are (scene/step_rule.hpp). The paper's method, its
  // 5th-order Gear predictor-corrector at 5e-5 s, is
  // --set integrator.kind="gear" --set integrator.dt=5e-5.
  s.integrator = f.choice("integrator.kind", {"leapfrog", "gear"}, "leapfrog");
  s.dt = f.positive("integrator.dt", f.number("integrator.dt", box_step_rule(s).dt));
  // The skin changes no force, only the cost (the list is exact at any skin).
  // 1.0 cm measured fastest, 11 % over 0.5 cm on 1 and 2 threads, once the
  // grains' cells no longer follow the big disk (docs/speed_accuracy.md,
  // "The neighbour list"; builds every 18 steps instead of every 9).
  s.skin = f.positive("neighbor.skin", f.number("neighbor.skin", 1.0));

  s.settle = f.non_negative("run.settle", f.number("run.settle", 1.0));
  s.duration = f.non_negative("run.duration", f.number("run.duration"));
  s.snapshot_every_cycles = f.positive("run.snapshot_every_cycles", f.number("run.snapshot_every_cycles", 1.0));
  s.trace_per_cycle = f.integer("run.trace_per_cycle", 20);
  if (s.trace_per_cycle < 1) f.fail("run.trace_per_cycle", "must be >= 1");

  f.text("paper.note", "");
  if (s.big && 2.0 * s.big_radius >= s.width)
    f.fail("big.radius", "the big disk does not fit in the box: diameter " + number_text(2.0 * s.big_radius) +
                             " >= box.width = " + number_text(s.width) + " (" + f.origin("box.width") + ")");
  // box_particles places grains on a square lattice of pitch 2 R_max + 0.1.
  if (s.width < 2.0 * s.radius_max + 0.1)
    f.fail("box.width", "too small for its particles: " + number_text(s.width) + " is narrower than one grain of radius " +
                            number_text(s.radius_max) + " (particles.radius_max, " + f.origin("particles.radius_max") +
                            ") with its placement clearance (" + number_text(2.0 * s.radius_max + 0.1) + ")");
  if (!s.smooth_walls && s.wall_spacing > 2.0 * s.wall_radius + 2.0 * s.radius_min)
    f.fail("box.wall_spacing", "leaves gaps wider than the smallest grain");
  // Limits (scene_file.hpp), before box_particles counts lattice rows and wall
  // particles in integers.
  if (static_cast<double>(s.count) > kMaxParticles)
    f.fail("particles.count", "more than one run can hold (" + number_text(kMaxParticles) + ")");
  const double pitch = 2.0 * s.radius_max + 0.1, per_row = std::max(1.0, std::floor(s.width / pitch));
  const double packed = std::ceil(static_cast<double>(s.count) / per_row) * pitch;
  const double walls = (s.width + 2.0 * s.wall_radius) / s.wall_spacing +
                       2.0 * (std::max(s.wall_height, packed) + s.wall_radius) / s.wall_spacing;
  if (!s.smooth_walls && walls > kMaxParticles)
    f.fail(s.wall_height > packed ? "box.wall_height" : "box.width",
           "the walls would need about " + number_text(walls) + " wall particles (box.wall_spacing " + number_text(s.wall_spacing) +
               "), more than one run can hold (" + number_text(kMaxParticles) + ")");
  if ((s.settle + s.duration) / s.dt > kMaxSteps)
    f.fail("run.duration", "would take " + number_text((s.settle + s.duration) / s.dt) + " steps (integrator.dt " +
                               number_text(s.dt) + "), more than " + number_text(kMaxSteps));
  if (std::lround((s.settle + s.duration) / s.dt) < 1)
    f.fail("run.duration", "the run (run.settle " + number_text(s.settle) + " s + run.duration " +
                               number_text(s.duration) + " s) rounds to 0 steps of integrator.dt " + number_text(s.dt) +
                               " s: nothing would be simulated");
  return s;
}

}  // namespace

BoxScene read_box_scene(SceneFile& f) {
  static const auto known = SceneFile::keys_read_by(read_fields, kMinimalBox, "<built-in shaken-box scene>");
  return f.read_checked(read_fields, known);
}

double BoxScene::cycle(double t) const {
  ShakerMotion<2> m;
  m.f0 = frequency;
  m.f1 = ramp_to;
  m.start = settle;
  m.ramp_start = ramp_start;
  m.ramp_time = ramp_time;
  return m.phase(t) / (2.0 * M_PI);
}

ParticleStore<2> box_particles(const BoxScene& s, std::vector<Eigen::Vector2d>& anchors, double* side_top) {
  const double rw = s.wall_radius, half = 0.5 * s.width;
  std::mt19937_64 gen(s.seed);
  auto uni = [&] { return static_cast<double>(gen() >> 11) * 0x1.0p-53; };
  const Eigen::Vector2d big_c(0.0, s.big_gap + s.big_radius);

  // Small disks on a loose square lattice (pitch 2 R_max + 0.1 cm), jittered,
  // from the floor up, skipping the big disk; they settle during run.settle.
  struct Grain {
    Eigen::Vector2d x, v;
    double r;
  };
  std::vector<Grain> grains;
  const double pitch = 2.0 * s.radius_max + 0.1;
  const int per_row = std::max(1, static_cast<int>(std::floor(s.width / pitch)));
  double top = 0.0;
  for (int row = 0; static_cast<long>(grains.size()) < s.count; ++row) {
    const double y = s.radius_max + 0.05 + row * pitch;
    for (int c = 0; c < per_row && static_cast<long>(grains.size()) < s.count; ++c) {
      const double x = -half + pitch * (c + 0.5) + 0.04 * (uni() - 0.5);
      if (s.big && std::hypot(x - big_c.x(), y - big_c.y()) < s.big_radius + s.radius_max + 0.05) continue;
      const double r = s.radius_min + (s.radius_max - s.radius_min) * uni();  // R uniform in [0.85, 1.15]
      grains.push_back({{x, y}, {0.5 * (uni() - 0.5), 0.5 * (uni() - 0.5)}, r});
      top = std::max(top, y + r);
    }
  }

  ParticleStore<2> p;
  anchors.clear();
  const double wall_m = s.mass(rw);
  auto add_wall = [&](double x, double y) {
    // Wall particles: prescribed motion, no rotation. Their own mass enters
    // m_eff (Eq. (5)) unless box.wall_mass = "infinite".
    p.add({x, y}, Eigen::Vector2d::Zero(), Ang<2>::Zero(), 2 * rw, wall_m, 0.5 * wall_m * rw * rw, kWallSpecies);
    if (s.wall_infinite_mass) p.inv_m.back() = 0.0;
    anchors.emplace_back(x, y);
  };
  // Side walls as high as asked, and at least above the loose initial packing.
  const double height = std::max(s.wall_height, top + pitch);
  const double rows = std::ceil((height + rw) / s.wall_spacing);  // side-wall particles per wall
  if (side_top) *side_top = -rw + rows * s.wall_spacing;
  if (!s.smooth_walls) {
    const int n_side = static_cast<int>(rows);  // read_fields bounds it
    // Floor: centres at y = -rw (floor surface at y = 0), spanning the side walls.
    const double xw = half + rw;  // side-wall centre lines
    const int n_floor = static_cast<int>(std::ceil(2 * xw / s.wall_spacing));
    for (int k = 0; k <= n_floor; ++k) add_wall(-xw + 2 * xw * k / n_floor, -rw);
    for (int k = 1; k <= n_side; ++k) {
      const double y = -rw + k * s.wall_spacing;
      add_wall(-xw, y);
      add_wall(xw, y);
    }
  }
  if (s.big) {
    const double m = s.mass(s.big_radius);
    p.add(big_c, Eigen::Vector2d::Zero(), Ang<2>::Zero(), 2 * s.big_radius, m,
          s.inertia_factor * m * s.big_radius * s.big_radius, 1);
  }
  for (const auto& g : grains) {
    const double m = s.mass(g.r);
    p.add(g.x, g.v, Ang<2>::Zero(), 2 * g.r, m, s.inertia_factor * m * g.r * g.r, 0);  // uniform disk: I = m R^2 / 2
  }
  return p;
}

}  // namespace granular
