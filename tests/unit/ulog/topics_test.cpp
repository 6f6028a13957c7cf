// The topic formats against the IDL's other compiled form: Cyclone's type descriptor (its ops carry every
// member's offset and primitive kind). A member the IDL parse missed, misnamed or misplaced shows here.
#include <gtest/gtest.h>

#include <dds/dds.h>

#include <algorithm>
#include <string>
#include <vector>

#include "rejuv/msgs/topic_types.hpp"
#include "rejuv/ulog/topics.hpp"

namespace rejuv::ulog {
namespace {

struct OpMember {
  std::size_t offset;
  std::string basic;  // the ULog type of a primitive member; "" for arrays, enums and structs
};

// The top-level members of a descriptor, in order, from its ops (dds_opcodes.h).
std::vector<OpMember> op_members(const dds_topic_descriptor_t& d) {
  std::vector<OpMember> out;
  // m_nops counts instructions (RTS included), not words.
  for (std::uint32_t i = 0, n = 0; n < d.m_nops; ++n) {
    const std::uint32_t op = d.m_ops[i];
    if (DDS_OP(op) == DDS_OP_RTS) break;
    EXPECT_EQ(DDS_OP(op), DDS_OP_ADR) << d.m_typename << ": an op this test does not know";
    if (DDS_OP(op) != DDS_OP_ADR) break;
    const std::uint32_t type = DDS_OP_TYPE(op);
    const bool fp = (op & DDS_OP_FLAG_FP) != 0, sgn = (op & DDS_OP_FLAG_SGN) != 0;
    std::string basic;
    std::uint32_t width = 2;
    switch (type) {
      case DDS_OP_VAL_1BY: basic = sgn ? "int8_t" : "uint8_t"; break;
      case DDS_OP_VAL_2BY: basic = sgn ? "int16_t" : "uint16_t"; break;
      case DDS_OP_VAL_4BY: basic = fp ? "float" : sgn ? "int32_t" : "uint32_t"; break;
      case DDS_OP_VAL_8BY: basic = fp ? "double" : sgn ? "int64_t" : "uint64_t"; break;
      case DDS_OP_VAL_ENU: width = 3; break;
      case DDS_OP_VAL_EXT: width = 3; break;
      case DDS_OP_VAL_ARR:
        width = DDS_OP_SUBTYPE(op) == DDS_OP_VAL_STU ? 5 : DDS_OP_SUBTYPE(op) == DDS_OP_VAL_ENU ? 4 : 3;
        break;
      default: ADD_FAILURE() << d.m_typename << ": op type " << type << " not handled"; return out;
    }
    out.push_back({d.m_ops[i + 1], basic});
    i += width;
  }
  return out;
}

TEST(UlogTopics, EveryTopicType_HasALayout) {
  ASSERT_EQ(topic_layouts().size(), msgs::all_topic_types().size());
  for (const msgs::TopicType& t : msgs::all_topic_types()) {
    const TopicLayout* l = find_layout(t.name);
    ASSERT_NE(l, nullptr) << t.name;
    EXPECT_EQ(l->size, t.size) << t.name;
  }
}

TEST(UlogTopics, Members_CoverTheStructWithoutOverlap) {
  for (const TopicLayout& l : topic_layouts()) {
    std::size_t cursor = 0;
    for (const FieldAt& m : l.members) {
      EXPECT_EQ(m.offset, cursor) << l.idl_name << "." << m.field.name;
      const std::size_t one = basic_size(m.field.type);
      ASSERT_GT(one, 0u) << l.idl_name << "." << m.field.name << ": flattened members are basic";
      cursor += one * (m.field.array == 0 ? 1 : m.field.array);
    }
    EXPECT_EQ(cursor, l.size) << l.idl_name;
  }
}

TEST(UlogTopics, TopLevelMembers_MatchTheCycloneDescriptor) {
  for (const msgs::TopicType& t : msgs::all_topic_types()) {
    const TopicLayout* l = find_layout(t.name);
    ASSERT_NE(l, nullptr);
    const std::vector<OpMember> ops = op_members(*t.descriptor);
    // Each op member starts a run of flattened members at its offset; primitive ones are one member of its type.
    for (const OpMember& op : ops) {
      const auto it = std::find_if(l->members.begin(), l->members.end(),
                                   [&](const FieldAt& m) { return m.offset == op.offset && !m.field.name.starts_with("_"); });
      ASSERT_NE(it, l->members.end()) << t.name << ": no member at offset " << op.offset;
      if (!op.basic.empty()) {
        EXPECT_EQ(it->field.type, op.basic) << t.name << "." << it->field.name;
        EXPECT_EQ(it->field.array, 0u) << t.name << "." << it->field.name;
      }
    }
    // … and as many top-level members as the descriptor has ("gyro_1.x" belongs to "gyro", "truth.p" to "truth").
    std::vector<std::string> top;
    for (const FieldAt& m : l->members) {
      if (m.field.name.starts_with("_")) continue;
      std::string head = m.field.name;
      if (const auto dot = head.find('.'); dot != std::string::npos) {
        head.resize(dot);
        if (const auto us = head.rfind('_'); us != std::string::npos &&
            head.find_first_not_of("0123456789", us + 1) == std::string::npos) {
          head.resize(us);
        }
      }
      if (top.empty() || top.back() != head) top.push_back(head);
    }
    EXPECT_EQ(top.size(), ops.size()) << t.name;
  }
}

TEST(UlogTopics, SensorGyro_NamesAndTypesFromTheIdl) {
  const TopicLayout* l = find_layout("rejuv::msg::SensorGyro");
  ASSERT_NE(l, nullptr);
  const Format f = topic_format("sensor_gyro", *l);
  EXPECT_EQ(format_text(f),
            "sensor_gyro:uint64_t timestamp;uint64_t timestamp_ns;double[3] omega_B_rad_s;double temperature_c;");
}

TEST(UlogTopics, SrMode_EnumIsA32BitInteger) {
  const TopicLayout* l = find_layout("rejuv::msg::SrMode");
  ASSERT_NE(l, nullptr);
  const Format f = topic_format("sr_mode", *l);
  EXPECT_EQ(format_text(f), "sr_mode:uint64_t timestamp;uint64_t timestamp_ns;uint32_t mode;uint32_t epoch;uint64_t generation;");
}

TEST(UlogTopics, NestedArrays_FlattenedWithIndex) {
  const TopicLayout* l = find_layout("rejuv::msg::MissionWaypoints");
  ASSERT_NE(l, nullptr);
  std::vector<std::string> names;
  for (const FieldAt& m : l->members) names.push_back(m.field.name);
  EXPECT_NE(std::find(names.begin(), names.end(), "waypoints_0.p_N_m"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "waypoints_15.yaw_rad"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "acceptance_radius_m"), names.end());
}

TEST(UlogTopics, EveryTopicFormat_AcceptedByTheEncoder) {
  Encoder e(0);
  for (const TopicLayout& l : topic_layouts()) {
    std::string name(l.idl_name.substr(l.idl_name.rfind(':') + 1));
    ASSERT_TRUE(e.format(topic_format(name, l))) << l.idl_name;
    EXPECT_EQ(e.format_size(name), 8 + l.size) << l.idl_name;
  }
}

}  // namespace
}  // namespace rejuv::ulog

namespace rejuv::ulog {
namespace {

TEST(UlogTopics, StructPadding_BecomesPaddingFields) {
  const TopicLayout* l = find_layout("rejuv::msg::SecurityEvent");
  ASSERT_NE(l, nullptr);
  EXPECT_EQ(format_text(topic_format("security_event", *l)),
            "security_event:uint64_t timestamp;uint64_t timestamp_ns;uint32_t service_id;uint32_t slot;"
            "uint8_t operation;uint8_t error;uint8_t[2] _padding0;uint32_t mode;uint32_t kind;uint8_t[4] _padding1;");
}

}  // namespace
}  // namespace rejuv::ulog
