#include <gtest/gtest.h>

#include "rejuv/msgs/topic_types.hpp"

namespace rejuv::msgs {
namespace {

TEST(TopicTypes, EveryType_FixedSizeDescriptorMatchesStruct) {
  ASSERT_FALSE(all_topic_types().empty());
  for (const TopicType& t : all_topic_types()) {
    ASSERT_NE(t.descriptor, nullptr) << t.name;
    EXPECT_EQ(t.descriptor->m_size, t.size) << t.name;
    EXPECT_NE(t.descriptor->m_flagset & DDS_TOPIC_FIXED_SIZE, 0U) << t.name << " is not fixed-size";
  }
}

TEST(TopicTypes, Find_KnownAndUnknownNames) {
  const TopicType* gyro = find_topic_type("rejuv::msg::SensorGyro");
  ASSERT_NE(gyro, nullptr);
  EXPECT_EQ(gyro->size, sizeof(rejuv_msg_SensorGyro));
  EXPECT_EQ(find_topic_type("rejuv::msg::Nope"), nullptr);
  EXPECT_EQ(TopicTraits<rejuv_msg_ActuatorControls>::name, "rejuv::msg::ActuatorControls");
}

TEST(TopicTypes, Names_Unique) {
  const auto types = all_topic_types();
  for (std::size_t i = 0; i < types.size(); ++i) {
    for (std::size_t j = i + 1; j < types.size(); ++j) {
      EXPECT_NE(types[i].name, types[j].name);
    }
  }
}

}  // namespace
}  // namespace rejuv::msgs
