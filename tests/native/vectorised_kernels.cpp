// Every batch kernel (a loop under `#pragma omp simd`, contact/pair_batch.hpp)
// instantiated in each dimension it runs in, for
// tests/python/test_vectorised.py: the compiler reports which loops it
// vectorised, and that test requires every such loop to be among them for
// AVX2 and for AVX-512. A kernel that stays scalar still gives the right
// forces, only slower (the pair loop by half on an AVX2 machine), so no
// force test would notice. Compiled by that test only, not part of a target.
#include "contact/linear.hpp"
#include "contact/rapaport.hpp"

namespace granular {
template void LinearLaw<2>::pair_force_batch(PairBatch<2>&) const;
template void LinearLaw<3>::pair_force_batch(PairBatch<3>&) const;
template void RapaportLaw<2>::pair_force_batch(PairBatch<2>&) const;
template void RapaportLaw<3>::pair_force_batch(PairBatch<3>&) const;
}  // namespace granular
