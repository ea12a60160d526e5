// The contact laws, registered. Each law is one header in contact/ (its
// equations once, as lane functions: contact/lane.hpp) declaring
//
//   kName          its contact.law key
//   kInDim         whether it is written for this dimension
//   kVectorised    whether the loops run it in SIMD batches (contact/pair_batch.hpp)
//   kRangeFactor, range(d_i, d_j), kSpecies, coulomb_mu, wall_coulomb_mu
//   pair_lane, and wall_lane where smooth walls can touch it
//   from_rapaport(MappingInputs)   if a scene of Rapaport's particles (the drum,
//                                  the particles scene) can use it
//   from_box(BoxScene)             if the shaken box can use it
//
// and one line below. The scenes' simulation types (engine/drum.hpp,
// engine/box.hpp, engine/particles.hpp), their contact.law keys, the list in
// `granular info --json` and the two-body battery every law must pass
// (tests/native/test_law_battery.cpp) all follow from this list.
#pragma once
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "contact/linear.hpp"
#include "contact/poeschel_herrmann.hpp"
#include "contact/rapaport.hpp"
#include "contact/viscel.hpp"
#include "core/type_list.hpp"

namespace granular {

template <int Dim>
using ContactLaws = TypeList<RapaportLaw<Dim>,                                 // Rapaport (2002), Eqs. (1)-(5)
                             LinearLaw<Dim>,                                   // LAMMPS gran/hooke, mapped
                             ViscElLaw<Dim>,                                   // YADE ViscElPhys, mapped
                             PoeschelHerrmannLaw<Dim, Damping::normal>,        // Poeschel & Herrmann (1995)
                             PoeschelHerrmannLaw<Dim, Damping::literal>>;      // ... Eq. (2) as printed

// The reading of Poeschel and Herrmann's damping a law has (contact.damping):
// its kDamping, or the normal component for every other law.
template <class Law, class = void>
struct DampingOf : std::integral_constant<Damping, Damping::normal> {};
template <class Law>
struct DampingOf<Law, std::void_t<decltype(Law::kDamping)>> : std::integral_constant<Damping, Law::kDamping> {};

inline const char* damping_name(Damping d) { return d == Damping::literal ? "literal" : "normal"; }

// Whether Op<Args...> names a type (the detection idiom).
template <class, template <class...> class Op, class... Args>
struct Detected : std::false_type {};
template <template <class...> class Op, class... Args>
struct Detected<std::void_t<Op<Args...>>, Op, Args...> : std::true_type {};

// Whether In (the scene's parameters) can set the law: from_rapaport(In) or from_box(In).
template <class Law, class In>
using FromRapaportCall = decltype(Law::from_rapaport(std::declval<const In&>()));
template <class Law, class In>
using FromBoxCall = decltype(Law::from_box(std::declval<const In&>()));
template <class Law, class In>
using FromRapaport = Detected<void, FromRapaportCall, Law, In>;
template <class Law, class In>
using FromBox = Detected<void, FromBoxCall, Law, In>;

// The laws a scene of Rapaport's particles (3D, parameters In = MappingInputs)
// can use, and those the shaken box (2D, In = BoxScene) can use.
template <template <class, class> class From, class In>
struct SettableFrom {
  template <class Law>
  struct Test : std::bool_constant<Law::kInDim && From<Law, In>::value> {};
};
template <class In>
using RapaportSceneLaws = Filter<SettableFrom<FromRapaport, In>::template Test, ContactLaws<3>>;
template <class In>
using BoxSceneLaws = Filter<SettableFrom<FromBox, In>::template Test, ContactLaws<2>>;

// The contact.law keys of a list of laws, each once, in the list's order.
template <class... L>
std::vector<std::string> law_names(TypeList<L...>) {
  std::vector<std::string> names;
  for (const char* n : {L::kName...}) {
    bool seen = false;
    for (const auto& m : names) seen = seen || m == n;
    if (!seen) names.emplace_back(n);
  }
  return names;
}

// Calls f(TypeTag<Law>{}) for the law of list L with this key and damping
// reading; returns false if there is none.
template <class L, class F>
bool with_law(L, const std::string& name, Damping damping, F&& f) {
  bool found = false;
  for_each_type(L{}, [&](auto tag) {
    using Law = typename decltype(tag)::type;
    if (!found && name == Law::kName && damping == DampingOf<Law>::value) {
      found = true;
      f(tag);
    }
  });
  return found;
}

}  // namespace granular
