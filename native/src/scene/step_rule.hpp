// The default time step of a scene, chosen from its physics (docs/speed_accuracy.md,
// "Defaults"): the largest step that is at most the scene's accuracy step and
// resolves the shortest contact the scene can produce with a measured number
// of steps.
//
// Drum. Rapaport's normal force (Eq. (1)) stiffens without bound as r -> 0, so
// a contact is shorter the faster the impact. The fastest impact the drum can
// produce is a grain falling across the whole drum onto grains carried up by
// the wall: v = sqrt(2 g D) + |Omega| D/2 (the initial collapse of the fcc
// fill, Sec. IV, is where it happens). The contact at that speed is timed for
// the lightest pair (two grains of the smallest diameter d_s - spread) and the
// lightest grain on the wall, twice the time from first touch to the turning
// point under Eqs. (1)-(2) (the whole contact when gamma_n = 0; a bound below it
// otherwise, and defined when the collision is overdamped).
//
// Particles scene. The drum's rule at the fastest impact the initial state
// can produce: each particle at most as fast as the fastest one, plus the speed
// the initial overlaps' energy would give the lightest (release_speed), plus
// free fall across the particles' height under gravity; two such particles
// meet head-on at twice that speed, a particle hits a wall at that speed. The
// contacts are timed for two of the smallest particles and the smallest on a
// wall (when the scene has walls).
//
// Box. The paper's linear spring-dashpot (Eq. (2) of Poeschel & Herrmann) has
// a contact period independent of the impact speed: pi / sqrt(Y/m_eff - (gamma_N/2)^2)
// for two of the lightest grains.
#pragma once

#include <string>

namespace granular {

struct DrumScene;
struct BoxScene;
struct ParticlesScene;

struct StepRule {
  double accuracy_step = 0.0;      // the largest step the scene's observables allow
  double impact_speed = 0.0;       // fastest impact the scene can produce (0: not used)
  double contact_time = 0.0;       // shortest contact at that speed
  double steps_per_contact = 0.0;  // required steps per shortest contact
  double dt = 0.0;                 // min(accuracy_step, contact_time / steps_per_contact), 2 significant digits
  std::string binding;             // "accuracy" or "contact"
};

// The measured constants (docs/speed_accuracy.md, "Defaults"; docs/stability.md).
// Drum: leapfrog under Rapaport's law, over the collapse and first half
// rotation, seeds 1-4: the worst failure seen was at 3.2 steps per fastest
// contact (#T at 0.009, 1 seed of 4); #T at 3.6 (0.008) and #J at 3.3 (0.01)
// survived every seed. 4 steps keep #A at its accuracy step 0.01.
inline constexpr double kDrumAccuracyStep = 0.01;
inline constexpr double kDrumStepsPerContact = 4.0;
// Box: Gear fails at 3.4 steps per contact, the leapfrog at 1.7; 2 x Gear's.
inline constexpr double kBoxAccuracyStep = 2e-4;
inline constexpr double kBoxStepsPerContact = 6.8;

// Twice the compression time of a head-on Rapaport collision at speed v:
// m_eff r'' = f_v(r) - gamma_n r' from r = 2^(1/6) d_ij, r' = -v, until r' = 0.
double rapaport_contact_bound(double dij, double meff, double gamma_n, double v);

// Fields of the scene read before integrator.dt (scene/drum_scene.cpp, box_scene.cpp).
StepRule drum_step_rule(const DrumScene& s);
StepRule box_step_rule(const BoxScene& s);
StepRule particles_step_rule(const ParticlesScene& s);

}  // namespace granular
