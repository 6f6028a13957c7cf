// A topic's DDS name and type under Rejuv's and ROS 2's names (rejuv/msgs/dds_naming.hpp). That Cyclone
// accepts the renamed descriptor and a ROS 2 reader decodes what it carries: tests/ros2_msgs.
#include "rejuv/msgs/dds_naming.hpp"

#include <gtest/gtest.h>

#include <string>

namespace rejuv::msgs {
namespace {

TEST(DdsNaming, TopicName_RejuvAndRos2Prefixes) {
  EXPECT_EQ(dds_topic_name("vehicle_state", DdsNaming::Rejuv), "rejuv/vehicle_state");
  EXPECT_EQ(dds_topic_name("vehicle_state", DdsNaming::Ros2), "rt/vehicle_state");
}

TEST(DdsNaming, Ros2TypeName_PackageMsgDdsUnderscore) {
  EXPECT_EQ(ros2_message_name("rejuv::msg::VehicleStateEstimate"), "VehicleStateEstimate");
  EXPECT_EQ(ros2_dds_type_name("rejuv::msg::VehicleStateEstimate"), "rejuv_msgs::msg::dds_::VehicleStateEstimate_");
  EXPECT_EQ(ros2_message_name("hello::Summary"), "");
}

TEST(DdsNaming, RejuvType_IsTheIdlType) {
  const TopicType* idl = find_topic_type("rejuv::msg::SensorGyro");
  ASSERT_NE(idl, nullptr);
  EXPECT_EQ(&dds_topic_type(*idl, DdsNaming::Rejuv), idl);
}

TEST(DdsNaming, Ros2Type_EveryTopicTypeRenamedSameLayout) {
  for (const TopicType& idl : all_topic_types()) {
    const TopicType& ros = dds_topic_type(idl, DdsNaming::Ros2);
    EXPECT_EQ(ros.name, idl.name) << "the policy's name stays";
    EXPECT_EQ(ros.size, idl.size);
    EXPECT_EQ(ros.align, idl.align);
    ASSERT_NE(ros.descriptor, nullptr);
    EXPECT_STREQ(ros.descriptor->m_typename, ros2_dds_type_name(idl.name).c_str());
    EXPECT_EQ(ros.descriptor->m_ops, idl.descriptor->m_ops) << "the same serialisation";
    EXPECT_EQ(ros.descriptor->m_size, idl.descriptor->m_size);
    EXPECT_EQ(ros.descriptor->m_flagset & DDS_TOPIC_XTYPES_METADATA, 0u) << idl.name;
    EXPECT_EQ(ros.descriptor->type_information.sz, 0u);
    EXPECT_EQ(&dds_topic_type(idl, DdsNaming::Ros2), &ros) << "made once";
  }
}

TEST(DdsNaming, DdsTopic_NameAndTypeTogether) {
  const TopicType* idl = find_topic_type("rejuv::msg::VehicleStateEstimate");
  ASSERT_NE(idl, nullptr);
  const DdsTopic t = dds_topic("vehicle_state", *idl, DdsNaming::Ros2);
  EXPECT_EQ(t.name, "rt/vehicle_state");
  ASSERT_NE(t.type, nullptr);
  EXPECT_STREQ(t.type->descriptor->m_typename, "rejuv_msgs::msg::dds_::VehicleStateEstimate_");
}

}  // namespace
}  // namespace rejuv::msgs
