// What the GPU path's kernels share between the drum (3D, periodic along its
// axis, replicas side by side) and the shaken box (2D, open, no pair of two
// wall particles), one source for both builds (gpu/exec.hpp): the particles'
// arrays, a pair's contact through the law's pair_lane, the health check's
// overlaps, and the cell sort and full neighbour list. The scene's
// differences are template parameters chosen once per stepper: the domain's
// minimum image (Domain), and which pairs the list leaves out (Filter).
//
// A build, for the replicas marked for renewal: their reference positions
// are set to the current ones; then particles are sorted by the cell of their
// reference position and, within a cell, by id (sort_pairs; the cells keyed by
// replica and, within a replica, numbered along a space-filling curve), each
// cell's range in the sorted order is found, and every particle lists every
// neighbour of its replica within range + skin of the reference positions (a
// full list, in the order of the cell stencil, each cell's particles by id):
// a replica's list depends on its own reference positions only. The list
// grows until every row fits.
//
// Particles are identified by id (their index in the models' order) and held
// in memory in slots. Between the sort and the list the stepper may move
// them to the sorted order (KernelStepper::reorder): the particles of a cell,
// and of nearby cells, then lie side by side in memory, which is what a GPU's
// memory needs. Either way each row lists the same ids in the same order, so
// the sums, and the results, are the same bits.
#pragma once
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "contact/lane.hpp"
#include "gpu/exec.hpp"

namespace granular::gpu {
inline namespace GRANULAR_EXEC_NS {

// |dr|^2, summed axis by axis.
template <int Dim>
GRANULAR_HD double norm2(const double (&dr)[Dim]) {
  double r2 = dr[0] * dr[0];
  for (int a = 1; a < Dim; ++a) r2 += dr[a] * dr[a];
  return r2;
}

// A domain without periodic axes: the separation of two particles is the
// difference of their positions.
template <int Dim>
struct OpenDomain {
  GRANULAR_HD void min_image(double (&)[Dim]) const {}
};

// The particles' columns both scenes have, structure of arrays: vector
// columns by component, x[a * n + i], the spin and torque with kAngDim<Dim>
// components. Raw pointers into the stepper's DeviceArrays; each scene's
// arrays (DrumArrays, BoxArrays) add theirs.
struct ParticleArrays {
  double* x;
  double* v;
  double* w;
  double* f;
  double* t;
  const double* d;
  const double* inv_m;
  const double* inv_i;
  const std::int32_t* species;
};

// Particle i's side of the pair (i, j): the contact through the law's
// pair_lane, if the two are within the law's range; returns whether they are.
// The inputs are formed as the CPU pair loop forms them (dr = r_i - r_j after
// the domain's minimum image, v = v_i - v_j).
template <class Law, int Dim, class Domain>
GRANULAR_HD bool pair_side(const Law& law, const Domain& domain, const ParticleArrays& s, unsigned n, unsigned i,
                           unsigned j, PairForce<Dim>& o) {
  PairContact<Dim> c;
  for (int a = 0; a < Dim; ++a) c.dr[a] = s.x[a * n + i] - s.x[a * n + j];
  domain.min_image(c.dr);
  c.r2 = norm2(c.dr);
  c.di = s.d[i];
  c.dj = s.d[j];
  const double rc = Law::range(c.di, c.dj);
  if (!(c.r2 < rc * rc)) return false;
  for (int a = 0; a < Dim; ++a) c.v[a] = s.v[a * n + i] - s.v[a * n + j];
  for (int a = 0; a < kAngDim<Dim>; ++a) {
    c.wi[a] = s.w[a * n + i];
    c.wj[a] = s.w[a * n + j];
  }
  c.ci = s.species[i];
  c.cj = s.species[j];
  c.inv_mi = s.inv_m[i];
  c.inv_mj = s.inv_m[j];
  law.pair_lane(c, o);
  return true;
}

// The full list as the kernels read it: row i's column m is
// nbr[m * n + i], m < count[i].
struct ListRows {
  const std::uint32_t* nbr;
  const std::uint32_t* count;
};

// Particle i's side of every listed pair in range (pair_side) added to its
// force f and torque t, in list order.
template <class Law, int Dim, class Domain>
GRANULAR_HD void add_listed_pairs(const Law& law, const Domain& domain, const ParticleArrays& s, unsigned n,
                                  const ListRows& list, unsigned i, double (&f)[Dim], double (&t)[kAngDim<Dim>]) {
  for (std::uint32_t m = 0, me = list.count[i]; m < me; ++m) {
    PairForce<Dim> pf;
    if (!pair_side(law, domain, s, n, i, list.nbr[m * n + i], pf)) continue;
    for (int a = 0; a < Dim; ++a) f[a] += pf.f[a];
    for (int a = 0; a < kAngDim<Dim>; ++a) t[a] += pf.ti[a];
  }
}

// Particle i's force f and torque t into its columns.
template <int Dim>
GRANULAR_HD void store_force(const ParticleArrays& s, unsigned n, unsigned i, const double (&f)[Dim],
                             const double (&t)[kAngDim<Dim>]) {
  for (int a = 0; a < Dim; ++a) s.f[a * n + i] = f[a];
  for (int a = 0; a < kAngDim<Dim>; ++a) s.t[a * n + i] = t[a];
}

// What the list needs of the particles, structure of arrays (x[a * n + i]):
// the positions, the reference positions it is built from (written where a
// replica renews them) and the diameters.
struct ListPositions {
  const double* x;
  double* x_ref;
  const double* d;
  unsigned n;
};

// The cells: at least range + skin wide, so every listed pair lies in the
// same or an adjacent cell; a periodic axis too short for three cells is one
// cell (the minimum image then finds the nearest copy), as in
// neighbor/cell_list.hpp.
template <int Dim>
struct CellGrid {
  int n[Dim];
  bool periodic[Dim];
  double lo[Dim], width[Dim];

  // Particle coordinate x's cell along axis a; a particle a little outside
  // a non-periodic edge belongs to the edge cell.
  GRANULAR_HD int coord(double x, int a) const {
    double q = std::floor((x - lo[a]) / width[a]);
    q = q >= 0.0 ? q : 0.0;  // and NaN to 0
    q = q <= n[a] - 1 ? q : n[a] - 1;
    return static_cast<int>(q);
  }
  // The cell's index in its replica's grid: x fastest after y, then z.
  GRANULAR_HD unsigned index(const int (&q)[Dim]) const {
    unsigned k = static_cast<unsigned>(q[1]) * n[0] + static_cast<unsigned>(q[0]);
    for (int a = 2; a < Dim; ++a) k = k * n[a] + static_cast<unsigned>(q[a]);
    return k;
  }
  // Cells per replica.
  GRANULAR_HD unsigned cells() const {
    unsigned c = static_cast<unsigned>(n[0]);
    for (int a = 1; a < Dim; ++a) c *= n[a];
    return c;
  }
};

// Every pair is listed.
struct AllPairs {
  struct Row {
    GRANULAR_HD bool skip(std::uint32_t) const { return false; }
  };
  GRANULAR_HD Row row(unsigned) const { return {}; }
};

// No pair of two particles of species `exclude` (the box's wall particles,
// Simulation::exclude_species; -1: every pair is listed).
struct NoPairWithinSpecies {
  const std::int32_t* species;
  int exclude;

  struct Row {
    const std::int32_t* species;
    int exclude;
    bool excluded;  // the row's particle is of the species
    GRANULAR_HD bool skip(std::uint32_t j) const { return excluded && species[j] == exclude; }
  };
  GRANULAR_HD Row row(unsigned i) const { return {species, exclude, species[i] == exclude}; }
};

// The positions the list is built from: the current ones for the particles
// of the replicas that rebuild (renew[r] != 0), the last build's for the
// others; then the key of the cell of slot i's reference position in its
// replica's grid (cell_key: the cells keyed by replica, and within a replica
// along the curve), stored by the particle's id with the id itself (the
// values the sort carries): sorted, the ids come in the order of their
// cells, and within a cell by id, wherever they are held.
template <int Dim>
struct CellOf {
  ListPositions s;
  const CellGrid<Dim>* grids;  // by replica
  const std::uint32_t* base;   // by replica: its first cell index
  const std::uint32_t* cell_key;
  const std::uint32_t* replica;  // by slot
  const std::uint32_t* renew;
  const std::uint32_t* id;  // by slot
  std::uint32_t* cell;      // by id
  std::uint32_t* ids;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    const std::uint32_t r = replica[i];
    const CellGrid<Dim> grid = grids[r];
    const bool moved = renew[r] != 0;
    int q[Dim];
    for (int a = 0; a < Dim; ++a) {
      if (moved) s.x_ref[a * n + i] = s.x[a * n + i];
      q[a] = grid.coord(s.x_ref[a * n + i], a);
    }
    const std::uint32_t k = id[i];
    cell[k] = cell_key[base[r] + grid.index(q)];
    ids[k] = k;
  }
};

// The slot of the k-th particle in the sorted order.
struct SlotsOf {
  const std::uint32_t* sorted_ids;
  const std::uint32_t* slot_of;  // by id
  std::uint32_t* slots;
  GRANULAR_HD void operator()(unsigned k) const { slots[k] = slot_of[sorted_ids[k]]; }
};

// Cell coordinates' Morton code: the bits of q[0], q[1] (and q[2])
// interleaved, the order of the cells along a Z-shaped space-filling curve.
template <int Dim>
std::uint64_t morton(const int (&q)[Dim]) {
  std::uint64_t code = 0;
  for (int b = 0; b < 64 / Dim; ++b)
    for (int a = 0; a < Dim; ++a) code |= ((static_cast<std::uint64_t>(q[a]) >> b) & 1u) << (b * Dim + a);
  return code;
}

// Every cell's range [start, end) in the sorted order, from the sorted keys
// (cells start empty: ClearRanges).
struct CellRanges {
  const std::uint32_t* sorted_cell;
  std::uint32_t* start;
  std::uint32_t* end;
  unsigned n;

  GRANULAR_HD void operator()(unsigned k) const {
    const std::uint32_t c = sorted_cell[k];
    if (k == 0 || sorted_cell[k - 1] != c) start[c] = k;
    if (k + 1 == n || sorted_cell[k + 1] != c) end[c] = k + 1;
  }
};

struct ClearRanges {
  std::uint32_t* start;
  std::uint32_t* end;
  GRANULAR_HD void operator()(unsigned c) const {
    start[c] = 0;
    end[c] = 0;
  }
};

// visit(o) for every offset o with first[a] <= o[a] <= last[a], as nested
// loops from axis A on (the last axis innermost); each axis's loop is its own,
// so that the offsets stay in registers.
template <int A, int Dim, class Visit>
GRANULAR_HD void for_stencil(const int (&first)[Dim], const int (&last)[Dim], int (&o)[Dim], const Visit& visit) {
  if constexpr (A == Dim) {
    visit(o);
  } else {
    for (o[A] = first[A]; o[A] <= last[A]; ++o[A]) for_stencil<A + 1>(first, last, o, visit);
  }
}

// Particle i's full neighbour list: every j != i of i's replica within
// range(d_i, d_j) + skin at the reference positions (the domain's minimum
// image), but the pairs the filter leaves out, from the 3^Dim cells around
// i's (fewer at a non-periodic edge or on a collapsed axis), in a fixed
// order: the cells by offset (the last axis fastest), each cell's particles
// by id. Column m of row i is nbr[m * n + i], a slot (neighbouring threads
// write neighbouring words); count[i] is the row's length, which may exceed
// cap: then the caller enlarges the list and builds again.
template <class Law, int Dim, class Domain, class Filter>
struct ListNeighbors {
  ListPositions s;
  Domain domain;
  Filter filter;
  const CellGrid<Dim>* grids;  // by replica
  const std::uint32_t* base;   // by replica: its first cell index
  const std::uint32_t* cell_key;
  const std::uint32_t* replica;
  double skin;
  const std::uint32_t* start;
  const std::uint32_t* end;
  const std::uint32_t* slots;  // the sorted order's slots
  std::uint32_t* nbr;
  std::uint32_t* count;
  unsigned cap;

  GRANULAR_HD void operator()(unsigned i) const {
    const unsigned n = s.n;
    const double* xr = s.x_ref;
    double xi[Dim];
    for (int a = 0; a < Dim; ++a) xi[a] = xr[a * n + i];
    const double di = s.d[i];
    const auto row = filter.row(i);
    const CellGrid<Dim> grid = grids[replica[i]];
    const std::uint32_t first = base[replica[i]];
    int q[Dim], lo[Dim], hi[Dim], o[Dim];
    for (int a = 0; a < Dim; ++a) {
      q[a] = grid.coord(xi[a], a);
      if (grid.n[a] == 1) {
        lo[a] = hi[a] = 0;
      } else if (grid.periodic[a]) {
        lo[a] = -1;
        hi[a] = 1;
      } else {
        lo[a] = q[a] > 0 ? -1 : 0;
        hi[a] = q[a] < grid.n[a] - 1 ? 1 : 0;
      }
    }
    unsigned m = 0;
    for_stencil<0>(lo, hi, o, [&](const int(&off)[Dim]) {
      int cq[Dim];
      for (int a = 0; a < Dim; ++a) cq[a] = (q[a] + off[a] + grid.n[a]) % grid.n[a];
      const std::uint32_t c = cell_key[first + grid.index(cq)];
      for (std::uint32_t k = start[c], ke = end[c]; k < ke; ++k) {
        const std::uint32_t j = slots[k];
        if (j == i || row.skip(j)) continue;
        double dr[Dim];
        for (int a = 0; a < Dim; ++a) dr[a] = xi[a] - xr[a * n + j];
        domain.min_image(dr);
        const double r2 = norm2(dr);
        const double rc = Law::range(di, s.d[j]) + skin;
        if (r2 < rc * rc) {
          if (m < cap) nbr[m * n + i] = j;
          ++m;
        }
      }
    });
    count[i] = m;
  }
};

// Whether particle i's position, velocity and spin (spin components a
// particle) are finite: v - v is 0 for a finite v, NaN for an infinite or NaN
// one.
template <int Dim, int Spin>
GRANULAR_HD bool finite_motion(const double* x, const double* v, const double* w, unsigned n, unsigned i) {
  double zero = 0.0;
  for (int a = 0; a < Dim; ++a) zero += (x[a * n + i] - x[a * n + i]) + (v[a * n + i] - v[a * n + i]);
  for (int a = 0; a < Spin; ++a) zero += w[a * n + i] - w[a * n + i];
  return zero == 0.0;
}

// Particle i's worst overlap over its listed pairs in range (positions x,
// diameters d), as a fraction of the contact distance, (range - r) / range
// with r the centres' distance (engine/health.hpp's measure); -infinity
// without one.
template <class Law, int Dim, class Domain>
GRANULAR_HD double worst_listed_overlap(const double* x, const double* d, unsigned n, const Domain& domain,
                                        const ListRows& list, unsigned i) {
  double worst = -std::numeric_limits<double>::infinity();
  for (std::uint32_t m = 0, me = list.count[i]; m < me; ++m) {
    const unsigned j = list.nbr[m * n + i];
    double dr[Dim];
    for (int a = 0; a < Dim; ++a) dr[a] = x[a * n + i] - x[a * n + j];
    domain.min_image(dr);
    const double r = std::sqrt(norm2(dr));
    const double rc = Law::range(d[i], d[j]);
    const double ov = (rc - r) / rc;
    if (r < rc && ov > worst) worst = ov;
  }
  return worst;
}

// The cell sort and the full list of one stepper's replicas, in device
// memory: `replica` gives each slot's replica, `renew` (one word a replica)
// which replicas renew their reference positions at a build, `id` each slot's
// particle and `slot_of` each particle's slot. A build is sort(), then (after
// the stepper has moved the particles, if it does) list().
template <int Dim>
class NeighborList {
 public:
  // Each replica's grid (grids[r]: replica r's; replicas of one scene whose
  // widest particles differ have cells of other widths), for n particles in
  // all, rows of `cap` columns to start with; `who` names the stepper in
  // errors. Replica r's cells are keyed after those of the replicas before it,
  // and within it in the order of their Morton codes.
  void reserve(const std::vector<CellGrid<Dim>>& grids, unsigned n, unsigned cap, const std::string& who) {
    n_ = n;
    cap_ = cap;
    std::vector<std::uint32_t> base, key;
    for (const CellGrid<Dim>& g : grids) {
      base.push_back(static_cast<std::uint32_t>(key.size()));
      if (key.size() + g.cells() >= std::numeric_limits<std::uint32_t>::max() / 2)
        throw std::invalid_argument(who + ": too many cells for 32-bit keys");
      std::vector<std::pair<std::uint64_t, std::uint32_t>> code(g.cells());
      for (std::uint32_t c = 0; c < g.cells(); ++c) code[c] = {morton<Dim>(coords(g, c).q), c};
      std::sort(code.begin(), code.end());
      const auto first = static_cast<std::uint32_t>(key.size());
      key.resize(key.size() + g.cells());
      for (std::uint32_t rank = 0; rank < g.cells(); ++rank) key[first + code[rank].second] = first + rank;
    }
    grids_.upload(grids);
    base_.upload(base);
    cell_key_.upload(key);
    end_bit_ = 1;
    while ((std::uint64_t{1} << end_bit_) < key.size()) ++end_bit_;
    cell_start_.resize(key.size());
    cell_end_.resize(key.size());
    cell_.resize(n_);
    ids_.resize(n_);
    sorted_cell_.resize(n_);
    sorted_ids_.resize(n_);
    slots_.resize(n_);
    count_.resize(n_);
  }

  // A build's first half: the marked replicas' reference positions renewed,
  // and the particles' ids sorted by cell, and within a cell by id
  // (sorted_ids).
  void sort(const ListPositions& s, const std::uint32_t* replica, const std::uint32_t* renew,
            const std::uint32_t* id, Scratch& scratch) {
    for_each(n_, CellOf<Dim>{s, grids_.data(), base_.data(), cell_key_.data(), replica, renew, id, cell_.data(),
                             ids_.data()});
    sort_pairs(cell_.data(), sorted_cell_.data(), ids_.data(), sorted_ids_.data(), n_, end_bit_, scratch);
  }
  // The ids in the order of their cells, by the last sort().
  const std::uint32_t* sorted_ids() const { return sorted_ids_.data(); }

  // A build's second half: each cell's range in the sorted order and every
  // particle's row (the header's), the domain's minimum image and the
  // filter's pairs as Domain and Filter give them; slot_of gives each id's
  // slot now.
  template <class Law, class Domain, class Filter>
  void list(const ListPositions& s, const std::uint32_t* replica, const std::uint32_t* slot_of, const Domain& domain,
            const Filter& filter, double skin, Scratch& scratch) {
    for_each(n_, SlotsOf{sorted_ids_.data(), slot_of, slots_.data()});
    for_each(static_cast<unsigned>(cell_start_.size()), ClearRanges{cell_start_.data(), cell_end_.data()});
    for_each(n_, CellRanges{sorted_cell_.data(), cell_start_.data(), cell_end_.data(), n_});
    while (true) {
      nbr_.resize(static_cast<std::size_t>(cap_) * n_);
      for_each(n_, ListNeighbors<Law, Dim, Domain, Filter>{s, domain, filter, grids_.data(), base_.data(),
                                                           cell_key_.data(), replica, skin, cell_start_.data(),
                                                           cell_end_.data(), slots_.data(), nbr_.data(),
                                                           count_.data(), cap_});
      const std::uint32_t longest = max_of(count_.data(), n_, std::uint32_t{0}, max_count_, scratch);
      if (longest <= cap_) break;
      cap_ = longest + longest / 4 + 8;
    }
    ++builds_;
  }

  ListRows rows() const { return {nbr_.data(), count_.data()}; }
  long builds() const { return builds_; }

 private:
  // Cell c's coordinates in grid g (CellGrid::index inverted).
  static auto coords(const CellGrid<Dim>& g, std::uint32_t c) {
    struct Q {
      int q[Dim];
    } out{};
    for (int a = Dim - 1; a >= 2; --a) {
      out.q[a] = static_cast<int>(c % static_cast<unsigned>(g.n[a]));
      c /= static_cast<unsigned>(g.n[a]);
    }
    out.q[0] = static_cast<int>(c % static_cast<unsigned>(g.n[0]));
    out.q[1] = static_cast<int>(c / static_cast<unsigned>(g.n[0]));
    return out;
  }

  DeviceArray<CellGrid<Dim>> grids_;
  DeviceArray<std::uint32_t> base_;
  unsigned n_ = 0;
  int end_bit_ = 1;
  unsigned cap_ = 0;  // list columns per particle
  long builds_ = 0;
  DeviceArray<std::uint32_t> cell_key_, cell_, ids_, sorted_cell_, sorted_ids_, slots_, cell_start_, cell_end_, nbr_,
      count_, max_count_;
};

}  // namespace GRANULAR_EXEC_NS
}  // namespace granular::gpu
