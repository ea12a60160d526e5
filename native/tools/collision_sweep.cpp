// Accuracy of a binary collision against the time step, for every contact law
// and integrator the scenes use (docs/speed_accuracy.md):
//   collision_sweep DRUM_SCENE BOX_SCENE > sweep.json
// For each method, a head-on collision of two of the scene's smallest
// particles (drum: d = small_diameter - spread/2 at contact.impact_speed; box:
// R = radius_min at 10 cm/s), damped as the scene says and undamped, at steps
// of 4 ... 1000 per contact. Reported: restitution e and contact time t_c,
// their errors against a reference (the analytic linear spring-dashpot where
// there is one, else the same engine at 4000 steps per contact), and for the
// undamped collision |1 - e^2|, the energy error of one collision.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>

#include "contact/linear.hpp"
#include "contact/poeschel_herrmann.hpp"
#include "contact/rapaport.hpp"
#include "contact/viscel.hpp"
#include "engine/simulation.hpp"
#include "integrate/gear.hpp"
#include "integrate/leapfrog.hpp"
#include "scene/box_scene.hpp"
#include "scene/law_mapping.hpp"
#include "scene/scene_file.hpp"

using namespace granular;
using nlohmann::json;

namespace {

struct Outcome {
  double e = NAN, tc = NAN;
};

// Two equal particles of diameter d and mass m approach at v0 along x; e and
// t_c from the crossings of the contact distance (linear interpolation).
template <class Sim>
Outcome collide(Sim sim, double d, double m, double inertia, double v0, double dt) {
  constexpr int D = Sim::kDim;
  using V = Vec<D>;
  sim.domain.lo = V::Constant(-50.0);
  sim.domain.hi = V::Constant(50.0);
  sim.domain.finalize();
  sim.skin = 0.05 * d + 4.0 * v0 * dt;  // each particle moves v0 dt / 2 a step at most
  sim.integrator.dt = dt;
  const double rc = decltype(sim.law)::range(d, d);
  const double gap = 0.37 * v0 * dt;  // the contact starts inside the first step
  V x = V::Zero(), v = V::Zero();
  x[0] = -0.5 * (rc + gap);
  v[0] = 0.5 * v0;
  sim.p.add(x, v, Ang<D>::Zero(), d, m, inertia, 0);
  x[0] = -x[0];
  v[0] = -v[0];
  sim.p.add(x, v, Ang<D>::Zero(), d, m, inertia, 0);
  sim.init();
  auto sep = [&] {
    const std::size_t a = sim.p.id[0] == 0 ? 0 : 1;
    return std::pair{(sim.p.x[1 - a] - sim.p.x[a])[0], (sim.p.v[1 - a] - sim.p.v[a])[0]};
  };
  double t_in = -1, t_prev = 0;
  auto [r_prev, u_prev] = sep();
  for (long k = 0; k < 100000000L; ++k) {
    sim.step();
    auto [r, u] = sep();
    if (!std::isfinite(r)) return {};
    if (t_in < 0 && r < rc) t_in = t_prev + (r_prev - rc) / (r_prev - r) * dt;
    if (t_in >= 0 && r >= rc) {
      const double f = (rc - r_prev) / (r - r_prev);
      return {(u_prev + f * (u - u_prev)) / v0, t_prev + f * dt - t_in};
    }
    r_prev = r;
    u_prev = u;
    t_prev = sim.time;
  }
  return {};
}

struct Method {
  std::string name;
  std::function<Outcome(double dt, bool damped)> run;
  std::function<Outcome(bool damped)> analytic;  // may be empty
  double tc_guess;                               // for choosing the steps
  double scene_dt;                               // the scene's own step, swept too
};

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: collision_sweep DRUM_SCENE BOX_SCENE\n";
    return 2;
  }
  omp_set_num_threads(1);
  SceneFile df(argv[1], {});
  const DrumScene ds = read_drum_scene(df);
  SceneFile bf(argv[2], {});
  const BoxScene bs = read_box_scene(bf);

  const double d = ds.small_diameter - 0.5 * ds.diameter_spread, m = d * d * d, I = 0.5 * ds.kappa * m * d * d;
  const double v0 = ds.impact_speed;
  const LinearMapping lin = map_rapaport_to_linear(ds);
  const ViscElMapping ve = map_linear_to_viscel(ds, lin);
  const double dl = d * lin.diameter_scale;  // the linear laws' contact diameter
  const double R = bs.radius_min, M = bs.mass(R), J = 0.5 * M * R * R, V0 = 10.0;

  std::vector<Method> methods;
  methods.push_back({"drum rapaport leapfrog",
                     [&](double dt, bool damped) {
                       Simulation<3, RapaportLaw<3>, Leapfrog<3>> s;
                       s.law = RapaportLaw<3>::from_paper(damped ? ds.gamma_n : 0.0, 0, 0, 0, 0, ds.mu_max);
                       return collide(s, d, m, I, v0, dt);
                     },
                     [&](bool damped) {
                       const auto c = rapaport_collision(d, 0.5 * m, damped ? ds.gamma_n : 0.0, v0);
                       return Outcome{c.restitution, c.contact_time};
                     },
                     lin.pair_collision[0].contact_time, ds.dt});
  auto linear_run = [&](double dt, bool damped) {
    Simulation<3, LinearLaw<3>, Leapfrog<3>> s;
    s.law = lin.law;
    if (!damped)
      for (auto& c : s.law.pair) c.gamma_n = 0.0;
    return collide(s, dl, m, I, v0, dt);
  };
  auto linear_exact = [&](bool damped) {
    const auto& c = lin.law.pair[0];
    const auto col = linear_collision(c.kn / (0.5 * m), damped ? c.gamma_n : 0.0);
    return Outcome{col.restitution, col.contact_time};
  };
  methods.push_back({"drum linear leapfrog", linear_run, linear_exact, lin.pair_linear[0].contact_time, ds.dt});
  methods.push_back({"drum viscel leapfrog",
                     [&](double dt, bool damped) {
                       Simulation<3, ViscElLaw<3>, Leapfrog<3>> s;
                       s.law = ve.law;
                       if (!damped)
                         for (auto& mt : s.law.mat) mt.cn_per_mass = mt.cs_per_mass = 0.0;
                       return collide(s, dl, m, I, v0, dt);
                     },
                     {}, lin.pair_linear[0].contact_time, ds.dt});
  auto ph_exact = [&](bool damped) {
    const auto col = linear_collision(bs.young / (0.5 * M), damped ? bs.gamma_n : 0.0);
    return Outcome{col.restitution, col.contact_time};
  };
  auto ph = [&](auto integrator_tag) {
    return [&, integrator_tag](double dt, bool damped) {
      Simulation<2, PoeschelHerrmannLaw<2>, decltype(integrator_tag)> s;
      s.law.young = bs.young;
      s.law.gamma_n = damped ? bs.gamma_n : 0.0;
      s.law.gamma_s = bs.gamma_s;
      s.law.mu = bs.mu;
      return collide(s, 2 * R, M, J, V0, dt);
    };
  };
  const double ph_tc = ph_exact(true).tc;
  methods.push_back({"box poeschel-herrmann gear5", ph(Gear5<2>{}), ph_exact, ph_tc, bs.dt});
  methods.push_back({"box poeschel-herrmann leapfrog", ph(Leapfrog<2>{}), ph_exact, ph_tc, bs.dt});

  json out = json::array();
  const std::vector<double> per_contact = {4, 6, 8, 12, 16, 24, 32, 48, 64, 100, 150, 250, 400, 1000};
  for (const auto& mth : methods)
    for (bool damped : {true, false}) {
      const Outcome ref = mth.analytic ? mth.analytic(damped) : mth.run(mth.tc_guess / 4000.0, damped);
      std::vector<double> steps = per_contact;
      steps.push_back(mth.tc_guess / mth.scene_dt);
      std::sort(steps.begin(), steps.end());
      for (double n : steps) {
        const double dt = n == mth.tc_guess / mth.scene_dt ? mth.scene_dt : mth.tc_guess / n;
        const Outcome o = mth.run(dt, damped);
        out.push_back({{"method", mth.name},
                       {"damped", damped},
                       {"steps_per_contact", n},
                       {"dt", dt},
                       {"scene_dt", dt == mth.scene_dt},
                       {"restitution", o.e},
                       {"contact_time", o.tc},
                       {"reference_restitution", ref.e},
                       {"reference_contact_time", ref.tc},
                       {"reference", mth.analytic ? "analytic" : "4000 steps per contact"},
                       {"restitution_error", std::abs(o.e - ref.e)},
                       {"contact_time_rel_error", std::abs(o.tc - ref.tc) / ref.tc},
                       {"energy_error", damped ? NAN : std::abs(1.0 - o.e * o.e)}});
      }
    }
  std::cout << out.dump(1) << "\n";
  return 0;
}
