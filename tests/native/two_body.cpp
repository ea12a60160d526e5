// Test helper: a few particles under one contact law, stepped by the native
// engine, trajectory printed as JSON. tests/python/test_lammps_agreement.py
// runs the same set-up in LAMMPS and compares.
//   two_body < setup.json > trajectory.json
// setup: {"law": "linear" | "hooke2d" | "viscel" | "viscel2d", "dt", "steps", "gravity": [..],
//         "coeff": {"pair": [[kn, gn, xt, mu] x 4 (ss, sb, bs, bb)], "wall": [[...] x 2]},
//         "viscel": {"materials": [[kn, cn_per_mass, cs_per_mass] x up to 3],
//                    "wall": [[kn, cn, cs] x up to 3]}  (YADE's law, contact/viscel.hpp),
//         "hooke": {"kn", "gamma_n", "gamma_t", "mu"},
//         "cylinder": {"diameter", "omega"} (3D only, optional),
//         "particles": [{"x", "v", "w", "d", "m", "I", "species"}]}
#include <iostream>
#include <nlohmann/json.hpp>

#include "boundary/cylinder_wall.hpp"
#include "contact/linear.hpp"
#include "contact/poeschel_herrmann.hpp"
#include "contact/viscel.hpp"
#include "engine/simulation.hpp"
#include "integrate/leapfrog.hpp"

using namespace granular;
using nlohmann::json;

namespace {

template <class Sim>
json trajectory(Sim& sim, const json& in) {
  constexpr int D = Sim::kDim;
  using V = Vec<D>;
  const double half = in.value("box_half_width", 20.0);
  sim.domain.lo = V::Constant(-half);
  sim.domain.hi = V::Constant(half);
  sim.domain.finalize();
  sim.skin = 0.3;
  sim.integrator.dt = in["dt"];
  for (int k = 0; k < D; ++k) sim.integrator.gravity[k] = in["gravity"][k];
  for (const auto& q : in["particles"]) {
    V x, v;
    Ang<D> w;
    for (int k = 0; k < D; ++k) x[k] = q["x"][k], v[k] = q["v"][k];
    for (int k = 0; k < w.size(); ++k) w[k] = q["w"][k];
    sim.p.add(x, v, w, q["d"], q["m"], q["I"], q["species"]);
  }
  sim.init();
  json out = json::array();
  const long steps = in["steps"];
  for (long s = 1; s <= steps; ++s) {
    sim.step();
    json row = json::array();
    for (std::int64_t id = 0; id < static_cast<std::int64_t>(sim.p.size()); ++id) {
      std::size_t i = 0;
      while (sim.p.id[i] != id) ++i;
      json r = json::array();
      for (int k = 0; k < D; ++k) r.push_back(sim.p.x[i][k]);
      for (int k = 0; k < D; ++k) r.push_back(sim.p.v[i][k]);
      for (int k = 0; k < sim.p.w[i].size(); ++k) r.push_back(sim.p.w[i][k]);
      row.push_back(r);
    }
    out.push_back(row);
  }
  return out;
}

}  // namespace

template <class Law>
void viscel_coefficients(Law& law, const json& in) {
  const auto& mats = in["viscel"]["materials"];
  for (std::size_t k = 0; k < mats.size(); ++k) law.mat[k] = {mats[k][0], mats[k][1], mats[k][2]};
  if (in["viscel"].contains("wall")) {
    const auto& w = in["viscel"]["wall"];
    for (std::size_t k = 0; k < w.size(); ++k) law.wall[k] = {w[k][0], w[k][1], w[k][2]};
  }
}

int main() {
  const json in = json::parse(std::cin);
  json out;
  if (in["law"] == "viscel") {
    Simulation<3, ViscElLaw<3>, Leapfrog<3>, CylinderWall> sim;
    viscel_coefficients(sim.law, in);
    auto& cyl = std::get<CylinderWall>(sim.walls);
    cyl.diameter = in.contains("cylinder") ? in["cylinder"]["diameter"].get<double>() : 1e6;
    cyl.omega = in.contains("cylinder") ? in["cylinder"]["omega"].get<double>() : 0.0;
    cyl.d_wall = 0.0;
    out = trajectory(sim, in);
  } else if (in["law"] == "viscel2d") {
    Simulation<2, ViscElLaw<2>, Leapfrog<2>> sim;
    viscel_coefficients(sim.law, in);
    out = trajectory(sim, in);
  } else if (in["law"] == "linear") {
    Simulation<3, LinearLaw<3>, Leapfrog<3>, CylinderWall> sim;
    for (int k = 0; k < 4; ++k) {
      const auto& c = in["coeff"]["pair"][k];
      sim.law.pair[k] = {c[0], c[1], c[2], c[3]};
    }
    for (int k = 0; k < 2; ++k) {
      const auto& c = in["coeff"]["wall"][k];
      sim.law.wall[k] = {c[0], c[1], c[2], c[3]};
    }
    auto& cyl = std::get<CylinderWall>(sim.walls);
    cyl.diameter = in.contains("cylinder") ? in["cylinder"]["diameter"].get<double>() : 1e6;
    cyl.omega = in.contains("cylinder") ? in["cylinder"]["omega"].get<double>() : 0.0;
    cyl.d_wall = 0.0;
    out = trajectory(sim, in);
  } else {
    Simulation<2, PoeschelHerrmannLaw<2>, Leapfrog<2>> sim;
    sim.law.young = in["hooke"]["kn"];
    sim.law.gamma_n = in["hooke"]["gamma_n"];
    sim.law.gamma_s = in["hooke"]["gamma_t"];
    sim.law.mu = in["hooke"]["mu"];
    out = trajectory(sim, in);
  }
  std::cout << out.dump() << "\n";
  return 0;
}
