// The fixture shared by the controller and setpoint tests (lqr_control, safety_control, gen_set_point, the
// lqr_control attack): the default control design, made once per test suite (a DARE and a Lyapunov solve).
#pragma once

#include <gtest/gtest.h>

#include <optional>
#include <utility>

#include "rejuv/flight/control_design.hpp"
#include "rejuv/flight_io/params.hpp"

namespace rejuv::services::testing {

class DefaultDesignTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto d = flight_io::control_design(flight_io::Params::from_table({}));
    ASSERT_TRUE(d) << d.error().to_string();
    design_.emplace(std::move(*d));
  }
  static void TearDownTestSuite() { design_.reset(); }
  void SetUp() override { ASSERT_TRUE(design_.has_value()); }

  static inline std::optional<flight::ControlDesign> design_;
};

}  // namespace rejuv::services::testing
