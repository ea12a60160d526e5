// From Rapaport's contact law to the nearest linear spring-dashpot
// (contact/linear.hpp, the law LAMMPS runs). docs/model_mapping.md derives it:
// for each type pair (and each species against the wall) the linear law gets
// the same overlap as Rapaport's law under the bed's static load (the weight of
// a column of grains D/2 high, F* = g m (D/2)/d at the mean grain), the same
// two-body restitution coefficient at a chosen impact speed, the same sliding
// friction (gamma_s) and the same Coulomb cap (mu). Matching the contact time
// of a slow collision instead gives springs so soft that the bed's weight
// pushes grains through the wall (docs/model_mapping.md).
// Particles keep their masses; their contact diameter becomes
// 2^(1/6) d (where Rapaport's force vanishes), and the walls move in by
// 2^(1/6) d_w / 2 so that contacts begin where they begin in Rapaport's model.
#pragma once
#include <stdexcept>
#include <string>
#include <vector>
#include "contact/linear.hpp"
#include "contact/viscel.hpp"
#include "contact/rapaport.hpp"
#include "scene/drum_scene.hpp"

namespace granular {

// The scene's Rapaport collisions have no linear equivalent (a collision that
// does not rebound); the message says which.
class MappingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Collision {
  double restitution = 0.0;   // separation speed / approach speed
  double contact_time = 0.0;  // time between first and last contact
};

// Head-on collision of two particles (or a particle and the wall) under
// Rapaport's normal force, Eqs. (1) and (2): the relative coordinate r obeys
// m_eff r'' = f_v(r) - gamma_n r', entering at r = 2^(1/6) d_ij with speed v.
Collision rapaport_collision(double dij, double meff, double gamma_n, double v);

// The linear law's collision (no clipping): omega^2 = k_n/m_eff - beta^2,
// beta = g_n/2, t_c = pi/omega, e = exp(-beta t_c).
Collision linear_collision(double kn, double gamma_n);  // kn per unit m_eff

// Overlap 2^(1/6) d - r at which Rapaport's elastic force f_v (Eq. (1)) equals F.
double rapaport_overlap(double dij, double force);

// k_n (per unit effective mass) and g_n giving restitution e and contact time t_c.
struct LinearNormal {
  double kn_per_mass = 0.0;  // k_n / m_eff
  double gamma_n = 0.0;      // g_n
};
LinearNormal linear_matching(const Collision& c);

struct LinearMapping {
  LinearLaw<3> law;
  double diameter_scale = 0.0;  // 2^(1/6): contact diameter / Rapaport diameter
  double wall_inset = 0.0;      // 2^(1/6) d_w / 2: how far the walls move in
  double impact_speed = 0.0;
  double static_load = 0.0;  // F*
  // The linear law's own collisions at these coefficients: [ss, sb, bb], wall [s, b].
  Collision pair_linear[3], wall_linear[2];
  // The pairs' Rapaport collisions that were matched: [ss, sb, bb], wall [s, b].
  Collision pair_collision[3], wall_collision[2];
  double pair_meff[3] = {0, 0, 0}, wall_meff[2] = {0, 0};
};

// What the mapping reads from a scene: each species' representative diameter
// (its mass d^3, Sec. III), the wall's diameter d_w, Rapaport's coefficients,
// the impact speed at which the collisions are matched, and the length that
// sets the static load F* = g m_bar (load_height / d_bar), the weight of a
// column of mean grains load_height high (F* = 0 without gravity: the springs
// then take Rapaport's stiffness at first touch, rapaport_stiffness).
struct MappingInputs {
  double d[2] = {1.0, 1.3};  // [small, big]
  double wall_diameter = 1.0;
  double gamma_n = 5.0, mu_max = 0.5;
  double gamma_s_bb = 0.0, gamma_s_ss = 0.0, gamma_s_bw = 0.0, gamma_s_sw = 0.0;
  double impact_speed = 1.0;
  double gravity = 0.0;
  double load_height = 0.0;
  RapaportLaw<3> rapaport() const {
    return RapaportLaw<3>::from_paper(gamma_n, gamma_s_bb, gamma_s_ss, gamma_s_bw, gamma_s_sw, mu_max);
  }
  // Rapaport's parameters as a scene of his particles (DrumScene,
  // ParticlesScene) names them; the diameters and the load are each scene's.
  template <class Scene>
  static MappingInputs parameters_of(const Scene& s) {
    MappingInputs in;
    in.wall_diameter = s.wall_diameter;
    in.gamma_n = s.gamma_n;
    in.mu_max = s.mu_max;
    in.gamma_s_bb = s.gamma_s_bb;
    in.gamma_s_ss = s.gamma_s_ss;
    in.gamma_s_bw = s.gamma_s_bw;
    in.gamma_s_sw = s.gamma_s_sw;
    in.impact_speed = s.impact_speed;
    in.gravity = s.gravity;
    return in;
  }
};

// The drum's: each species' mean diameter d - spread/2, the load of a column
// D/2 high.
MappingInputs mapping_inputs(const DrumScene& s);

// The secant stiffness F / overlap of Rapaport's elastic force (Eq. (1)) under
// the load F; at F = 0 its limit, the slope where f_v vanishes,
// -f_v'(2^(1/6) d_ij) = 72 / (2^(1/6) d_ij)^2.
double rapaport_stiffness(double dij, double force);

LinearMapping map_rapaport_to_linear(const MappingInputs& in);
inline LinearMapping map_rapaport_to_linear(const DrumScene& s) { return map_rapaport_to_linear(mapping_inputs(s)); }

// The deepest overlap, as a fraction of the contact distance, of a head-on
// collision at speed v under the mapped linear springs (undamped, so an upper
// bound: delta = v sqrt(m_eff / k_n)), over the species pairs and the wall.
double linear_overlap_fraction(const MappingInputs& in, const LinearMapping& m, double v);

// YADE's viscoelastic law (contact/viscel.hpp) as near to the linear law as
// YADE's mixing rule allows (docs/model_mapping.md, "YADE"). Per species s
// (mean mass m_s): kn = 2 k_n(ss), cn = g_n(ss) per unit mass, cs = x_t g_n(ss)
// per unit mass, which reproduces the same-species pairs exactly; the
// small-big pair gets what mixing gives. The wall material W of species s
// solves mix(particle value, W) = wanted value at m_s, which needs
// wanted < particle value; otherwise W = 0 (absent: the pair gets the
// particle's value) and the key is listed in `infeasible`.
struct ViscElMapping {
  ViscElLaw<3> law;
  double mean_mass[2] = {0, 0};
  std::vector<std::string> infeasible;
};
ViscElMapping map_linear_to_viscel(const MappingInputs& in, const LinearMapping& lin);

// Sets the registered law with this contact.law key from the scene's
// parameters (its from_rapaport, contact/laws.hpp) and throws MappingError if
// that cannot be done (a mapped law the scene's parameters cannot give).
void check_law_settable(const std::string& law, const MappingInputs& in);
// The same for a scene being read: a law that cannot be set fails the scene
// at contact.law with the reason.
void check_law_settable(SceneFile& f, const std::string& law, const MappingInputs& in);
inline ViscElMapping map_linear_to_viscel(const DrumScene& s, const LinearMapping& lin) {
  return map_linear_to_viscel(mapping_inputs(s), lin);
}

}  // namespace granular
