// The pair force of the Rapaport law (Sec. III, Eqs. (1)-(4)) evaluated through
// the engine's force loop, against the formulas written out independently.
#include <gtest/gtest.h>

#include "helpers.hpp"

using namespace granular;
using namespace granular::test;

namespace {

FreeSim pair_sim(const Eigen::Vector3d& xi, const Eigen::Vector3d& xj, const Eigen::Vector3d& vi,
                 const Eigen::Vector3d& vj, const Eigen::Vector3d& wi, const Eigen::Vector3d& wj, double di, double dj,
                 int ci, int cj, double gamma_n = 5.0) {
  omp_set_num_threads(1);
  FreeSim sim;
  open_box(sim, 10.0);
  sim.law = Law3::from_paper(gamma_n, 10, 2, 10, 2, 0.5);
  add_sphere(sim, xi, vi, wi, di, ci);
  add_sphere(sim, xj, vj, wj, dj, cj);
  sim.init();
  return sim;
}

std::size_t slot(const FreeSim& sim, int id) { return sim.p.id[0] == id ? 0 : 1; }

}  // namespace

TEST(PairForce, NormalPartIsMinusGradientOfPotential) {
  const double di = 1.1, dj = 0.9, dij = 1.0;
  for (double r : {0.9, 0.97, 1.05, 1.1}) {
    auto sim = pair_sim({0, 0, 0}, {r, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, di, dj, 0, 0, 0.0);
    const double h = 1e-6;
    const double dudr = (Law3::potential(r + h, dij) - Law3::potential(r - h, dij)) / (2 * h);
    // Force on i (at the origin, j at +x): -dU/dr along r^_ij = -x^.
    const double fx = sim.p.f[slot(sim, 0)].x();
    EXPECT_NEAR(fx, dudr, 1e-6 * std::abs(dudr)) << "r = " << r;
    EXPECT_NEAR(sim.p.f[slot(sim, 1)].x(), -fx, 1e-15);
  }
}

TEST(PairForce, FullContactMatchesEquations) {
  const Eigen::Vector3d xi(0.1, 0.2, 0.3), xj(0.9, 0.6, 0.1);
  const Eigen::Vector3d vi(0.5, -0.2, 0.1), vj(-0.3, 0.4, 0.2), wi(1, -2, 0.5), wj(0.3, 0.7, -1.5);
  const double di = 1.25, dj = 0.95;
  for (auto [ci, cj] : {std::pair{0, 0}, std::pair{1, 1}, std::pair{1, 0}}) {
    auto sim = pair_sim(xi, xj, vi, vj, wi, wj, di, dj, ci, cj);
    const Eigen::Vector3d r = xi - xj;
    const double rn = r.norm(), dij = 0.5 * (di + dj);
    ASSERT_LT(rn, std::pow(2.0, 1.0 / 6.0) * dij);
    const Eigen::Vector3d n = r / rn, v = vi - vj;
    const double fn = lj_magnitude(rn, dij) - 5.0 * n.dot(v);                          // (1), (2)
    const Eigen::Vector3d vs = v - n.dot(v) * n - ((di * wi + dj * wj) / (di + dj)).cross(r);  // (3)
    // gamma_s: ss 2, bb 10, bs min = 2; mu: ss 0.1, bb 0.5, bs min = 0.1
    const double g = (ci == 1 && cj == 1) ? 10.0 : 2.0, mu = (ci == 1 && cj == 1) ? 0.5 : 0.1;
    const Eigen::Vector3d fs = -std::min(g * vs.norm(), mu * std::abs(fn)) * vs.normalized();  // (4)
    const Eigen::Vector3d f = fn * n + fs;
    const auto a = slot(sim, 0), b = slot(sim, 1);
    EXPECT_LT((sim.p.f[a] - f).norm(), 1e-12 * f.norm());
    EXPECT_LT((sim.p.f[b] + f).norm(), 1e-12 * f.norm());
    // torque: subtract r^ x f_s / kappa from m d alpha  <=>  tau = -(d/2) r^ x f_s
    EXPECT_LT((sim.p.tq[a] + di / 2 * n.cross(fs)).norm(), 1e-12);
    EXPECT_LT((sim.p.tq[b] + dj / 2 * n.cross(fs)).norm(), 1e-12);
    // and the angular acceleration the paper states: m_i d_i alpha_i = -r^ x f_s / kappa
    const Eigen::Vector3d alpha = sim.p.tq[a] * sim.p.inv_i[a];
    const double mi = di * di * di;
    EXPECT_LT((mi * di * alpha + n.cross(fs) / 0.2).norm(), 1e-10);
  }
}

TEST(PairForce, CapBindsAtMuFn) {
  // Fast tangential slip: gamma_s |v_s| >> mu |f_n|.
  auto sim = pair_sim({0, 0, 0}, {1.0, 0, 0}, {0, 50, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, 1.0, 1.0, 1, 1);
  const auto a = slot(sim, 0);
  const double fn = -sim.p.f[a].x();  // repulsive: pushes i towards -x
  EXPECT_NEAR(std::abs(sim.p.f[a].y()), 0.5 * std::abs(fn), 1e-12);
  EXPECT_LT(sim.p.f[a].y(), 0.0);  // opposes the slip
}

TEST(PairForce, RollingContactHasNoFriction) {
  // Equal spheres rolling on each other: v_ij tangential cancels the rotation term.
  const double d = 1.0, r = 1.05, w = 2.0;
  // v_s = v_ij - wbar x r_ij with wbar = w z^ and r_ij = -r x^: wbar x r_ij = -w r y^.
  auto sim = pair_sim({0, 0, 0}, {r, 0, 0}, {0, -w * r, 0}, {0, 0, 0}, {0, 0, w}, {0, 0, w}, d, d, 0, 0);
  EXPECT_NEAR(sim.p.f[slot(sim, 0)].y(), 0.0, 1e-12);
  EXPECT_NEAR(sim.p.tq[slot(sim, 0)].norm(), 0.0, 1e-12);
}

TEST(PairForce, NoForceBeyondCutoff) {
  auto sim = pair_sim({0, 0, 0}, {1.13, 0, 0}, {0, 1, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, 1.0, 1.0, 0, 0);
  EXPECT_EQ(sim.p.f[0].norm(), 0.0);
}

TEST(PairForce, PaperFrictionRules) {
  // Table I run B: gamma bb=2, ss=10, bw=10, sw=2.
  const auto law = Law3::from_paper(5.0, 2.0, 10.0, 10.0, 2.0, 0.5);
  EXPECT_DOUBLE_EQ(law.pair[0].gamma_s, 10.0);  // ss
  EXPECT_DOUBLE_EQ(law.pair[3].gamma_s, 2.0);   // bb
  EXPECT_DOUBLE_EQ(law.pair[1].gamma_s, 2.0);   // bs = min
  EXPECT_DOUBLE_EQ(law.pair[0].mu, 0.5);        // larger of the pair is 0.5
  EXPECT_DOUBLE_EQ(law.pair[3].mu, 0.1);        // ratio as gamma: 0.5 * 2/10
  EXPECT_DOUBLE_EQ(law.wall[1].mu, 0.5);
  EXPECT_DOUBLE_EQ(law.wall[0].mu, 0.1);
  EXPECT_DOUBLE_EQ(law.wall[0].gamma_s, 2.0);
}
