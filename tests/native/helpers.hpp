// Small builders shared by the native tests.
#pragma once
#include <omp.h>

#include <cmath>
#include <functional>

#include "boundary/cylinder_wall.hpp"
#include "boundary/end_caps.hpp"
#include "boundary/periodic_axes.hpp"
#include "contact/rapaport.hpp"
#include "engine/simulation.hpp"
#include "integrate/leapfrog.hpp"

namespace granular::test {

using Law3 = RapaportLaw<3>;
// Periodic-capable: the tests choose the axes (Box::periodic).
using FreeSim = Simulation<3, Law3, Leapfrog<3>, PeriodicAxes>;
using OpenSim = Simulation<3, Law3, Leapfrog<3>>;
using CylSim = Simulation<3, Law3, Leapfrog<3>, CylinderWall, PeriodicAxes>;
using CapSim = Simulation<3, Law3, Leapfrog<3>, CylinderWall, EndCaps>;

// Mass d^3 and I = kappa m d^2 / 2 with kappa = 0.2 (Rapaport 2002, Sec. III).
template <class Sim>
void add_sphere(Sim& sim, const Eigen::Vector3d& x, const Eigen::Vector3d& v, const Eigen::Vector3d& w, double d,
                int species = 0) {
  const double m = d * d * d;
  sim.p.add(x, v, w, d, m, 0.1 * m * d * d, species);
}

template <class Sim>
void open_box(Sim& sim, double half) {
  sim.domain.lo = Eigen::Vector3d::Constant(-half);
  sim.domain.hi = Eigen::Vector3d::Constant(half);
  sim.domain.periodic = {false, false, false};
  sim.domain.finalize();
}

// Root of f on [a, b] by bisection to machine precision.
inline double bisect(const std::function<double(double)>& f, double a, double b) {
  double fa = f(a);
  for (int k = 0; k < 200; ++k) {
    const double m = 0.5 * (a + b);
    const double fm = f(m);
    if ((fm > 0) == (fa > 0)) { a = m; fa = fm; } else { b = m; }
  }
  return 0.5 * (a + b);
}

// Eq. (1) magnitude, written out again here independently of the engine.
inline double lj_magnitude(double r, double d) {
  const double s6 = std::pow(d / r, 6);
  return 48.0 / r * (s6 * s6 - 0.5 * s6);
}

}  // namespace granular::test
