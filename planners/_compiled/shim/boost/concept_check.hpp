// OMPL's headers include <boost/concept_check.hpp> only for BOOST_CONCEPT_ASSERT((boost::Convertible<A *, B *>)),
// compile-time checks of template arguments that change no layout: this stand-in checks the same with the
// standard library, so the extension builds without Boost.
#pragma once
#include <type_traits>

namespace boost {
template <typename From, typename To>
struct Convertible {
    static_assert(std::is_convertible<From, To>::value, "boost::Convertible (shim): not convertible");
};
}  // namespace boost

// used as BOOST_CONCEPT_ASSERT((boost::Convertible<A *, B *>)): `sizeof (boost::Convertible<...>)` instantiates it
#define BOOST_CONCEPT_ASSERT(concept) static_assert(sizeof concept > 0, "")
