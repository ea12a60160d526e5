// One vectorised kernel instantiated, chosen by KERNEL, for
// tests/python/test_vectorised.py: the compiler reports which loops it
// vectorised, and that test requires the loop under `#pragma omp simd` of
// each kernel to be among them, for AVX2 and for AVX-512, one kernel per
// compilation (so that one instantiation's report cannot stand for
// another's). A kernel that stays scalar still gives the right forces, only
// slower (the drum's pair loop by half on an AVX2 machine), so no force test
// would notice. Compiled by that test only, not part of a target.
#include "boundary/cylinder_wall.hpp"
#include "contact/linear.hpp"
#include "contact/rapaport.hpp"

namespace granular {
#if KERNEL == 1
template void pair_force_batch<LinearLaw<2>, 2>(const LinearLaw<2>&, PairBatch<2>&);
#elif KERNEL == 2
template void pair_force_batch<LinearLaw<3>, 3>(const LinearLaw<3>&, PairBatch<3>&);
#elif KERNEL == 3
template void pair_force_batch<RapaportLaw<2>, 2>(const RapaportLaw<2>&, PairBatch<2>&);
#elif KERNEL == 4
template void pair_force_batch<RapaportLaw<3>, 3>(const RapaportLaw<3>&, PairBatch<3>&);
#elif KERNEL == 5
template void wall_force_batch<LinearLaw<3>, 3>(const LinearLaw<3>&, WallBatch<3>&);
#elif KERNEL == 6
template void wall_force_batch<RapaportLaw<3>, 3>(const RapaportLaw<3>&, WallBatch<3>&);
#elif KERNEL == 7
template void CylinderWall::flush<RapaportLaw<3>>(ParticleStore<3>&, const RapaportLaw<3>&, WallBatch<3>&) const;
#else
#error "KERNEL selects the kernel: 1-7"
#endif
}  // namespace granular
