// Overloaded{lambdas...}: one visitor for std::visit out of one lambda per alternative.
#pragma once

namespace rejuv {

template <class... F>
struct Overloaded : F... {
  using F::operator()...;
};

}  // namespace rejuv
