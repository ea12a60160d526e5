// Lists of types, for the scene layer's choices: which laws, integrators and
// walls a scene can combine become one std::variant of simulation types
// (engine/drum.hpp, engine/box.hpp), and a scene's keys pick one alternative
// once, before the run.
#pragma once
#include <type_traits>
#include <variant>

namespace granular {

template <class... T>
struct TypeList {};

// A value standing for a type, for visiting a TypeList: for_each_type(L{}, f)
// calls f(TypeTag<T>{}) for each T of L, in order.
template <class T>
struct TypeTag {
  using type = T;
};

template <class... T, class F>
void for_each_type(TypeList<T...>, F&& f) {
  (f(TypeTag<T>{}), ...);
}

template <class... L>
struct ConcatT;
template <>
struct ConcatT<> {
  using type = TypeList<>;
};
template <class... A>
struct ConcatT<TypeList<A...>> {
  using type = TypeList<A...>;
};
template <class... A, class... B, class... R>
struct ConcatT<TypeList<A...>, TypeList<B...>, R...> {
  using type = typename ConcatT<TypeList<A..., B...>, R...>::type;
};
// The lists one after another.
template <class... L>
using Concat = typename ConcatT<L...>::type;

template <template <class> class Keep, class L>
struct FilterT;
template <template <class> class Keep, class... T>
struct FilterT<Keep, TypeList<T...>> {
  using type = Concat<std::conditional_t<Keep<T>::value, TypeList<T>, TypeList<>>...>;
};
// The types T of L with Keep<T>::value, in order.
template <template <class> class Keep, class L>
using Filter = typename FilterT<Keep, L>::type;

template <template <class> class F, class L>
struct FlatMapT;
template <template <class> class F, class... T>
struct FlatMapT<F, TypeList<T...>> {
  using type = Concat<F<T>...>;
};
// The lists F<T> (each a TypeList) of the types T of L, one after another.
template <template <class> class F, class L>
using FlatMap = typename FlatMapT<F, L>::type;

template <class L>
struct VariantOfT;
template <class... T>
struct VariantOfT<TypeList<T...>> {
  using type = std::variant<T...>;
};
// std::variant<T...> of TypeList<T...>.
template <class L>
using VariantOf = typename VariantOfT<L>::type;

}  // namespace granular
