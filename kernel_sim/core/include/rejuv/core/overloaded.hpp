// Overloaded{lambdas...}: one visitor for std::visit out of one lambda per alternative.
#pragma once

namespace rejuv {

template <class... F>
struct Overloaded : F... {
  using F::operator()...;
};
// C++20 deduces this for an aggregate by itself; clang-16 (the fuzz preset) does not yet (P1816).
template <class... F>
Overloaded(F...) -> Overloaded<F...>;

}  // namespace rejuv
