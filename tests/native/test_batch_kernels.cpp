// The vectorised paths compute what the scalar ones compute:
// - a law's batch kernel (contact/pair_batch.hpp) against its pair_force,
//   contact by contact, over random contacts that include capped, uncapped
//   and zero-sliding ones;
// - a law's wall batch kernel (contact/wall_batch.hpp) against its
//   wall_force, and the curved wall's batched contacts against its contacts
//   one by one;
// - the batched pair loop (engine/simulation.hpp) against an O(N^2) sum of
//   pair_force over every pair in range, periodic images included;
// - the neighbour build's vector pair tests (neighbor/range_scan.hpp: AVX-512,
//   AVX2, whichever the build has) against
//   its scalar form and the definition.
// Tolerances: the batch kernel may fuse a multiply and an add where the
// scalar code does not (or the reverse), which moves the last bit; 1e-12 of
// the force scale is a thousand times that and far below any physics.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "boundary/cylinder_wall.hpp"
#include "contact/linear.hpp"
#include "contact/pair_batch.hpp"
#include "contact/poeschel_herrmann.hpp"
#include "contact/rapaport.hpp"
#include "contact/viscel.hpp"
#include "contact/wall_batch.hpp"
#include "engine/simulation.hpp"
#include "integrate/leapfrog.hpp"
#include "neighbor/range_scan.hpp"

using namespace granular;

namespace {

constexpr double kRel = 1e-12;

// Coefficients that differ per species pair, symmetric in the pair (as
// scene/law_mapping.cpp builds them: the half list visits a pair in either order).
template <int Dim>
LinearLaw<Dim> linear_law() {
  LinearLaw<Dim> law;
  for (int ci = 0; ci < 2; ++ci)
    for (int cj = 0; cj < 2; ++cj) {
      const int k = ci + cj;
      law.pair[ci * 2 + cj] = {2e3 * (1 + k), 40.0 + k, 0.5, 0.3 + 0.1 * k};
    }
  for (int ci = 0; ci < 2; ++ci) law.wall[ci] = {3e3 * (1 + ci), 30.0 + ci, 0.6, 0.4 + 0.1 * ci};
  return law;
}
template <int Dim>
RapaportLaw<Dim> rapaport_law() {
  return RapaportLaw<Dim>::from_paper(5.0, 10.0, 2.0, 10.0, 2.0, 0.5);
}

template <int Dim>
Vec<Dim> random_vec(std::mt19937_64& gen, double scale) {
  std::normal_distribution<double> g(0.0, 1.0);
  Vec<Dim> v;
  for (int a = 0; a < Dim; ++a) v[a] = scale * g(gen);
  return v;
}
template <int Dim>
Ang<Dim> random_ang(std::mt19937_64& gen, double scale) {
  std::normal_distribution<double> g(0.0, 1.0);
  Ang<Dim> w;
  for (int a = 0; a < w.size(); ++a) w[a] = scale * g(gen);
  return w;
}

struct Contact {
  std::size_t capped = 0, uncapped = 0, still = 0;
  // Which branch of the friction law a contact's force f took (n: the
  // normal, mu: its Coulomb coefficient).
  template <class V>
  void count(const V& f, const V& n, double mu) {
    const double fn = f.dot(n);
    const double fs = (f - fn * n).norm();
    const double cap = mu * std::abs(fn);
    if (fs == 0.0)
      ++still;
    else if (std::abs(fs - cap) <= 1e-9 * cap)
      ++capped;
    else
      ++uncapped;
  }
};

// Random contacts through both paths; returns how many were capped,
// uncapped and without sliding, so that a test can insist on all three.
template <int Dim, class Law>
Contact check_batch_against_scalar(const Law& law, unsigned seed) {
  using V = Vec<Dim>;
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  PairBatch<Dim> b;
  struct Case {
    typename Law::PairResult r;
    int ci, cj;
  };
  std::vector<Case> expect;
  Contact seen;
  for (int round = 0; round < 40; ++round) {
    b.n = 0;
    expect.clear();
    for (int q = 0; q < PairBatch<Dim>::kSize - (round % 7); ++q) {
      const int ci = static_cast<int>(gen() % 2), cj = static_cast<int>(gen() % 2);
      const double di = ci ? 1.3 : 1.0, dj = cj ? 1.3 : 1.0;
      const double inv_mi = 1.0 / (di * di * di), inv_mj = 1.0 / (dj * dj * dj);
      V dir = random_vec<Dim>(gen, 1.0);
      dir.normalize();
      const double s = u(gen);
      const double r = Law::range(di, dj) * (1.0 - 0.1 * s * s * s);  // overlaps from 0 to 10 %
      V dr = r * dir;
      V v = random_vec<Dim>(gen, std::pow(10.0, -3.0 + 4.0 * u(gen)));
      Ang<Dim> wi = random_ang<Dim>(gen, 0.5), wj = random_ang<Dim>(gen, 0.5);
      if (q % 5 == 0) {  // sliding velocity exactly zero: along an axis, no spin
        dr = V::Zero();
        dr[0] = r;
        v = V::Zero();
        v[0] = 0.7 * u(gen) - 0.35;
        wi.setZero();
        wj.setZero();
      }
      b.i[q] = static_cast<std::uint32_t>(q);
      b.j[q] = static_cast<std::uint32_t>(q + 1);
      b.ci[q] = ci;
      b.cj[q] = cj;
      for (int a = 0; a < Dim; ++a) {
        b.dr[a][q] = dr[a];
        b.v[a][q] = v[a];
      }
      for (int a = 0; a < PairBatch<Dim>::kAng; ++a) {
        b.wi[a][q] = wi[a];
        b.wj[a][q] = wj[a];
      }
      b.r2[q] = dr.squaredNorm();
      b.di[q] = di;
      b.dj[q] = dj;
      b.inv_mi[q] = inv_mi;
      b.inv_mj[q] = inv_mj;
      expect.push_back({law.pair_force(dr, dr.squaredNorm(), di, dj, v, wi, wj, ci, cj, inv_mi, inv_mj), ci, cj});
      b.n = q + 1;
    }
    law.pair_force_batch(b);
    for (int q = 0; q < b.n; ++q) {
      const auto& c = expect[static_cast<std::size_t>(q)];
      const auto& e = c.r;
      const double scale = e.f.norm() + e.ti.norm() + e.tj.norm() + 1e-300;
      for (int a = 0; a < Dim; ++a) EXPECT_NEAR(b.f[a][q], e.f[a], kRel * scale) << "contact " << q << " axis " << a;
      for (int a = 0; a < PairBatch<Dim>::kAng; ++a) {
        EXPECT_NEAR(b.ti[a][q], e.ti[a], kRel * scale) << "contact " << q;
        EXPECT_NEAR(b.tj[a][q], e.tj[a], kRel * scale) << "contact " << q;
      }
      // Which branch of the friction law this contact took.
      V n;
      for (int a = 0; a < Dim; ++a) n[a] = b.dr[a][q];
      seen.count(e.f, n.normalized(), law.coulomb_mu(c.ci, c.cj));
    }
  }
  return seen;
}

// The random contacts reached every branch of the friction law.
void expect_every_branch(const Contact& seen) {
  EXPECT_GT(seen.capped, 0u);
  EXPECT_GT(seen.uncapped, 0u);
  EXPECT_GT(seen.still, 0u);
}

}  // namespace

TEST(BatchKernel, LinearLaw3DMatchesPairForce) {
  expect_every_branch(check_batch_against_scalar<3>(linear_law<3>(), 1));
}

TEST(BatchKernel, LinearLaw2DMatchesPairForce) {
  expect_every_branch(check_batch_against_scalar<2>(linear_law<2>(), 2));
}

TEST(BatchKernel, RapaportLaw3DMatchesPairForce) {
  expect_every_branch(check_batch_against_scalar<3>(rapaport_law<3>(), 3));
}

// A batch kernel that ignored a lane's species would fail here: the
// coefficients differ per species pair.
TEST(BatchKernel, SpeciesPairSelectsCoefficients) {
  auto law = linear_law<3>();
  PairBatch<3> b;
  b.n = 2;
  for (int q = 0; q < 2; ++q) {
    b.ci[q] = q;
    b.cj[q] = q;
    b.dr[0][q] = 0.9;  // overlap 0.1 of unit spheres at rest
    b.dr[1][q] = b.dr[2][q] = 0.0;
    b.r2[q] = 0.81;
    b.di[q] = b.dj[q] = 1.0;
    for (int a = 0; a < 3; ++a) b.v[a][q] = b.wi[a][q] = b.wj[a][q] = 0.0;
    b.inv_mi[q] = b.inv_mj[q] = 1.0;
  }
  law.pair_force_batch(b);
  EXPECT_NEAR(b.f[0][0], law.pair[0].kn * 0.1, 1e-9 * law.pair[0].kn);
  EXPECT_NEAR(b.f[0][1], law.pair[3].kn * 0.1, 1e-9 * law.pair[3].kn);
}

// Random wall contacts through both paths, as check_batch_against_scalar
// does for pairs: overlaps from 0 to 10 %, both species, sliding speeds
// over four decades, both of the curved wall's lever readings, and one
// contact in five without sliding. d_wall: the wall's diameter in the law's
// range (Rapaport's d_w = 1; the linear law's wall has none). terms(rp, di,
// ci): the size of the terms the normal force is the difference of (Eq. (1):
// 48 s^12 / r and 24 s^6 / r; the linear law's k_n R_i and k_n r). The
// kernel forms r = |r'_iw| as a sum of lanes where the scalar form has
// Eigen's norm; a last-bit change in r moves that difference by a few ulps
// of its terms, which for small overlaps is up to a thousand times 1e-12 of
// the net force. So a lane may differ by 1e-12 of the net force and
// torque plus 1e-14 (some 50 ulps) of the terms.
template <class Law, class Terms>
Contact check_wall_batch_against_scalar(const Law& law, double d_wall, Terms terms, unsigned seed) {
  using V = Vec<3>;
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  WallBatch<3> b;
  struct Case {
    typename Law::WallResult r;
    int ci;
  };
  std::vector<Case> expect;
  Contact seen;
  for (int round = 0; round < 40; ++round) {
    b.n = 0;
    expect.clear();
    for (int q = 0; q < WallBatch<3>::kSize - (round % 7); ++q) {
      const int ci = static_cast<int>(gen() % 2);
      const double di = ci ? 1.3 : 1.0, inv_mi = 1.0 / (di * di * di), d_iw = 0.5 * (di + d_wall);
      V dir = random_vec<3>(gen, 1.0);
      dir.normalize();
      const double s = u(gen);
      V rp = Law::range(di, d_wall) * (1.0 - 0.1 * s * s * s) * dir;
      V v = random_vec<3>(gen, std::pow(10.0, -3.0 + 4.0 * u(gen)));
      Ang<3> w = random_ang<3>(gen, 0.5);
      if (q % 5 == 0) {  // sliding velocity exactly zero: along an axis, no spin
        rp = V(rp.norm(), 0.0, 0.0);
        v = V(0.7 * u(gen) - 0.35, 0.0, 0.0);
        w.setZero();
      }
      const V lever = (q % 2 ? 1.0 : di / (di + d_wall)) * rp;  // the "paper" and "pair" readings
      b.i[q] = static_cast<std::uint32_t>(q);
      b.ci[q] = ci;
      for (int a = 0; a < 3; ++a) {
        b.rp[a][q] = rp[a];
        b.v[a][q] = v[a];
        b.w[a][q] = w[a];
        b.lever[a][q] = lever[a];
      }
      b.di[q] = di;
      b.d_iw[q] = d_iw;
      b.inv_mi[q] = inv_mi;
      expect.push_back({law.wall_force(rp, di, d_iw, v, w, lever, ci, inv_mi), ci});
      b.n = q + 1;
    }
    law.wall_force_batch(b);
    for (int q = 0; q < b.n; ++q) {
      const auto& e = expect[static_cast<std::size_t>(q)].r;
      const Vec<3> rp(b.rp[0][q], b.rp[1][q], b.rp[2][q]);
      const double scale =
          e.f.norm() + e.t.norm() + 1e-2 * terms(rp, b.di[q], expect[static_cast<std::size_t>(q)].ci) + 1e-300;
      for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(b.f[a][q], e.f[a], kRel * scale) << "contact " << q << " axis " << a;
        EXPECT_NEAR(b.t[a][q], e.t[a], kRel * scale) << "contact " << q << " axis " << a;
      }
      seen.count(e.f, V(b.rp[0][q], b.rp[1][q], b.rp[2][q]).normalized(),
                 law.wall_coulomb_mu(expect[static_cast<std::size_t>(q)].ci));
    }
  }
  return seen;
}

TEST(BatchKernel, RapaportWallMatchesWallForce) {
  const auto terms = [](const Vec<3>& rp, double di, int) {
    const double r = rp.norm(), s6 = std::pow(0.5 * (di + 1.0) / r, 6);
    return 48.0 * s6 * s6 / r;
  };
  expect_every_branch(check_wall_batch_against_scalar(rapaport_law<3>(), 1.0, terms, 21));
}

TEST(BatchKernel, LinearWallMatchesWallForce) {
  const auto law = linear_law<3>();
  const auto terms = [&](const Vec<3>&, double di, int ci) { return law.wall[ci].kn * 0.5 * di; };
  expect_every_branch(check_wall_batch_against_scalar(law, 0.0, terms, 22));
}

// A law as it is, but not vectorised: the curved wall then takes its
// contacts one by one.
template <class Law>
struct WithoutWallBatch : Law {
  static constexpr bool kVectorised = false;
  explicit WithoutWallBatch(const Law& law) : Law(law) {}
};

// The curved wall's batched contacts (the geometry in lanes, then the law's
// kernel) against its contacts one by one, over a block of a store with more
// contacts than a batch holds and more particles than a selection block;
// both lever readings, both laws. Particles outside the block are untouched.
template <class Law>
void check_curved_wall_batches(const Law& law, double d_wall) {
  static_assert(HasWallBatch<Law, 3>::value, "the law has a wall batch kernel");
  static_assert(!HasWallBatch<WithoutWallBatch<Law>, 3>::value, "the wrapper hides it");
  std::mt19937_64 gen(31);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  ParticleStore<3> p;
  for (int i = 0; i < 900; ++i) {
    const double d = i % 3 ? 1.0 : 1.3, m = d * d * d;
    const double phi = 2.0 * M_PI * u(gen), r = 8.1 - 0.5 * d - 3.0 * std::pow(u(gen), 3);  // some reach the wall
    const Eigen::Vector3d x(r * std::cos(phi), 40.0 * u(gen), r * std::sin(phi));
    p.add(x, random_vec<3>(gen, 0.5), random_ang<3>(gen, 0.5), d, m, 0.1 * m * d * d, i % 3 ? 0 : 1);
  }
  const std::size_t lo = 37, hi = 850;
  for (const auto& [paper, pair] : {std::pair{1.0, 0.0}, std::pair{0.0, 1.0}}) {
    CylinderWall wall;
    wall.diameter = 16.0;
    wall.omega = 0.7;
    wall.d_wall = d_wall;
    wall.lever = {paper, pair};
    ParticleStore<3> batched = p, single = p;
    wall.apply(batched, law, lo, hi, 0.0);
    wall.apply(single, WithoutWallBatch<Law>(law), lo, hi, 0.0);
    std::size_t touched = 0;
    double fscale = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i) fscale = std::max(fscale, single.f[i].norm() + single.tq[i].norm());
    for (std::size_t i = 0; i < p.size(); ++i) {
      EXPECT_LE((batched.f[i] - single.f[i]).norm(), kRel * fscale) << "particle " << i;
      EXPECT_LE((batched.tq[i] - single.tq[i]).norm(), kRel * fscale) << "particle " << i;
      if (i < lo || i >= hi) {
        EXPECT_EQ(batched.f[i].squaredNorm() + batched.tq[i].squaredNorm(), 0.0) << i;
      }
      touched += single.f[i].squaredNorm() > 0.0;
    }
    EXPECT_GT(touched, 3u * WallBatch<3>::kSize);  // several batches, and contacts in every selection block
    EXPECT_LT(touched, hi - lo);                    // and particles out of reach
  }
}

TEST(BatchKernel, CurvedWallBatchesMatchOneByOne) {
  check_curved_wall_batches(rapaport_law<3>(), 1.0);
  check_curved_wall_batches(linear_law<3>(), 0.0);
}

// The batched pair loop against an independent O(N^2) sum of pair_force, in a
// periodic box with contacts across the boundary.
TEST(BatchKernel, PairLoopMatchesDirectSum) {
  using Sim = Simulation<3, LinearLaw<3>, Leapfrog<3>, PeriodicAxes>;
  static_assert(HasPairBatch<LinearLaw<3>, 3>::value, "the linear law has a batch kernel");
  for (int threads : {1, 2}) {
    omp_set_num_threads(threads);
    Sim sim;
    sim.law = linear_law<3>();
    sim.domain.lo = Eigen::Vector3d(-4, -6, -4);
    sim.domain.hi = Eigen::Vector3d(4, 6, 4);
    sim.domain.periodic = {false, true, false};
    sim.domain.finalize();
    std::mt19937_64 gen(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int i = 0; i < 700; ++i) {
      Eigen::Vector3d x(-4 + 8 * u(gen), -6 + 12 * u(gen), -4 + 8 * u(gen));
      if (i < 60) x.y() = (i % 2 ? 5.7 : -5.8) + 0.2 * u(gen);  // across y = +-6
      const double d = i % 3 ? 1.0 : 1.3;
      const double m = d * d * d;
      sim.p.add(x, random_vec<3>(gen, 0.3), random_ang<3>(gen, 0.3), d, m, 0.1 * m * d * d, i % 3 ? 0 : 1);
    }
    sim.init();
    const auto& p = sim.p;
    std::vector<Eigen::Vector3d> F(p.size(), Eigen::Vector3d::Zero()), T(p.size(), Eigen::Vector3d::Zero());
    std::size_t contacts = 0, across = 0;
    for (std::size_t i = 0; i < p.size(); ++i)
      for (std::size_t j = i + 1; j < p.size(); ++j) {
        const Eigen::Vector3d raw = p.x[i] - p.x[j];
        const Eigen::Vector3d dr = sim.domain.min_image(raw);
        const double rc = LinearLaw<3>::range(p.d[i], p.d[j]);
        if (dr.squaredNorm() >= rc * rc) continue;
        ++contacts;
        across += std::abs(raw.y()) > 6.0;
        const auto r = sim.law.pair_force(dr, dr.squaredNorm(), p.d[i], p.d[j], p.v[i] - p.v[j], p.w[i], p.w[j],
                                          p.species[i], p.species[j], p.inv_m[i], p.inv_m[j]);
        F[i] += r.f;
        F[j] -= r.f;
        T[i] += r.ti;
        T[j] += r.tj;
      }
    ASSERT_GT(contacts, 500u);
    ASSERT_GT(across, 0u);
    double fscale = 0.0;
    for (const auto& f : F) fscale = std::max(fscale, f.norm());
    for (std::size_t i = 0; i < p.size(); ++i) {
      EXPECT_LE((p.f[i] - F[i]).norm(), kRel * fscale) << "particle id " << p.id[i] << ", " << threads << " threads";
      EXPECT_LE((p.tq[i] - T[i]).norm(), kRel * fscale) << "particle id " << p.id[i] << ", " << threads << " threads";
    }
  }
}

// The neighbour build's pair test lists exactly the particles the scalar
// form lists, in the same order, with the same count in contact, for ranges
// of every length mod 8, with and without an excluded species; and both
// agree with the definition (distance below factor (d_i + d_j) + skin, not
// both excluded). Diameters and positions are drawn so that about half the
// candidates are listed and a third of those in contact.
template <int Dim>
void check_pair_scan(unsigned seed) {
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  std::vector<double> x(Dim * 200), d(200);
  std::vector<std::int32_t> species(200);
  for (auto& c : x) c = u(gen);
  for (std::size_t j = 0; j < d.size(); ++j) {
    d[j] = 1.0 + 0.15 * u(gen);
    species[j] = static_cast<std::int32_t>(gen() % 3);
  }
  std::size_t listed_total = 0, contacts_total = 0, excluded_total = 0;
  for (std::uint32_t b = 0; b < 40; ++b)
    for (std::uint32_t e = b; e < b + 40; ++e) {
      double xs[Dim];
      for (int a = 0; a < Dim; ++a) xs[a] = 0.5 * u(gen);
      const bool excluded_i = (b + e) % 2 == 0;
      const PairScanRow row{xs, 1.0 + 0.15 * u(gen), 0.5 * (1.0 + 0.1 * (u(gen) + 2.0)), 0.4,
                            excluded_i ? species.data() : nullptr, 2};
      std::vector<std::uint32_t> s(e - b + kScanSlack);
      std::uint32_t cs = 0;
      const auto ns = pair_scan_scalar<Dim>(x.data(), d.data(), b, e, row, s.data(), cs) - s.data();
      // A vector form against the scalar one: the same particles in the same
      // order, the same contact count.
      [[maybe_unused]] const auto same_as_scalar = [&](const char* form, auto scan) {
        std::vector<std::uint32_t> v(e - b + kScanSlack);
        std::uint32_t cv = 0;
        const auto nv = scan(x.data(), d.data(), b, e, row, v.data(), cv) - v.data();
        ASSERT_EQ(ns, nv) << form << ", range [" << b << ", " << e << ")";
        ASSERT_EQ(cs, cv) << form << ", range [" << b << ", " << e << ")";
        for (long k = 0; k < ns; ++k) ASSERT_EQ(s[k], v[k]) << form;
      };
#ifdef GRANULAR_RANGE_SCAN_AVX512
      same_as_scalar("AVX-512", pair_scan_avx512<Dim>);
#endif
#ifdef GRANULAR_RANGE_SCAN_AVX2
      same_as_scalar("AVX2", pair_scan_avx2<Dim>);
#endif
      // Both against the definition (distances far from the cutoffs by
      // more than a rounding: a draw within 1e-12 would be a coincidence).
      std::vector<std::uint32_t> direct;
      std::uint32_t in_contact = 0;
      for (std::uint32_t j = b; j < e; ++j) {
        double r2 = 0.0;
        for (int a = 0; a < Dim; ++a) r2 += (xs[a] - x[Dim * j + a]) * (xs[a] - x[Dim * j + a]);
        const double r = std::sqrt(r2), r0 = row.factor * (row.di + d[j]);
        const bool both = excluded_i && species[j] == 2;
        excluded_total += both && r < r0 + row.skin;
        if (r < r0 + row.skin && !both) {
          direct.push_back(j);
          in_contact += r < r0;
        }
      }
      ASSERT_EQ(static_cast<std::size_t>(ns), direct.size()) << "range [" << b << ", " << e << ")";
      for (long k = 0; k < ns; ++k) ASSERT_EQ(s[k], direct[static_cast<std::size_t>(k)]);
      ASSERT_EQ(cs, in_contact);
      listed_total += static_cast<std::size_t>(ns);
      contacts_total += in_contact;
    }
  // The draws exercise every branch: pairs listed, in contact, excluded.
  EXPECT_GT(listed_total, 5000u);
  EXPECT_GT(contacts_total, 1000u);
  EXPECT_GT(excluded_total, 200u);
}

TEST(PairScan, VectorMatchesScalarAndDefinition3D) { check_pair_scan<3>(11); }
TEST(PairScan, VectorMatchesScalarAndDefinition2D) { check_pair_scan<2>(12); }

// Every law's range has the form the pair scan tests: kRangeFactor (d_i + d_j).
template <class Law>
void check_range_form() {
  std::mt19937_64 gen(5);
  std::uniform_real_distribution<double> u(0.1, 3.0);
  for (int k = 0; k < 1000; ++k) {
    const double a = u(gen), b = u(gen);
    ASSERT_EQ(Law::range(a, b), Law::kRangeFactor * (a + b));
  }
}
TEST(PairScan, LawsRangeIsFactorTimesDiameterSum) {
  check_range_form<RapaportLaw<3>>();
  check_range_form<LinearLaw<3>>();
  check_range_form<PoeschelHerrmannLaw<2, Damping::normal>>();
  check_range_form<ViscElLaw<3>>();
  EXPECT_GT(RapaportLaw<3>::kRangeFactor, 0.5);  // the LJ cut 2^(1/6) sigma, beyond contact
}
