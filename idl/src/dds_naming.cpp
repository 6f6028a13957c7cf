#include "rejuv/msgs/dds_naming.hpp"

#include <memory>
#include <vector>

#include "rejuv/core/dds_name.hpp"
#include "rejuv/core/result.hpp"

namespace rejuv::msgs {

namespace {

// idlc's descriptor of a struct under another type name. Its XTypes type information is left out: it
// describes the struct under its IDL name (the complete type object names it), so endpoints of the renamed
// type match by the type name alone, as ROS 2's own Cyclone endpoints (which carry none) do.
dds_topic_descriptor_t renamed(const dds_topic_descriptor_t& d, const char* type_name) {
  return dds_topic_descriptor_t{.m_size = d.m_size,
                                .m_align = d.m_align,
                                .m_flagset = d.m_flagset & ~DDS_TOPIC_XTYPES_METADATA,
                                .m_nkeys = d.m_nkeys,
                                .m_typename = type_name,
                                .m_keys = d.m_keys,
                                .m_nops = d.m_nops,
                                .m_ops = d.m_ops,
                                .m_meta = d.m_meta,
                                .type_information = {.data = nullptr, .sz = 0},
                                .type_mapping = {.data = nullptr, .sz = 0},
                                .restrict_data_representation = d.restrict_data_representation};
}

// A topic type under its ROS 2 type name; on the heap, once, so that the descriptor's name and the
// TopicType's descriptor pointer stay put.
struct Ros2Type {
  explicit Ros2Type(const TopicType& idl)
      : type_name(ros2_dds_type_name(idl.name)),
        descriptor(renamed(*idl.descriptor, type_name.c_str())),
        type{.name = idl.name, .size = idl.size, .align = idl.align, .descriptor = &descriptor} {}
  Ros2Type(const Ros2Type&) = delete;
  Ros2Type& operator=(const Ros2Type&) = delete;

  std::string type_name;
  dds_topic_descriptor_t descriptor;
  TopicType type;
};

// By index into all_topic_types(); built on first use (a function-local static: thread-safe, then read only).
const std::vector<std::unique_ptr<const Ros2Type>>& ros2_types() {
  static const std::vector<std::unique_ptr<const Ros2Type>> table = [] {
    std::vector<std::unique_ptr<const Ros2Type>> t;
    for (const TopicType& idl : all_topic_types()) t.push_back(std::make_unique<const Ros2Type>(idl));
    return t;
  }();
  return table;
}

}  // namespace

const TopicType& dds_topic_type(const TopicType& type, DdsNaming naming) {
  switch (naming) {
    case DdsNaming::Rejuv: return type;
    case DdsNaming::Ros2: break;
  }
  const TopicType* idl = find_topic_type(type.name);
  REJUV_ASSERT(idl != nullptr, "a type bridged under ROS 2 names is one of all_topic_types()");
  return ros2_types()[static_cast<std::size_t>(idl - all_topic_types().data())]->type;
}

DdsTopic dds_topic(std::string_view topic, const TopicType& type, DdsNaming naming) {
  return DdsTopic{.name = rejuv::dds_topic_name(topic, naming), .type = &dds_topic_type(type, naming)};
}

std::string_view ros2_message_name(std::string_view idl_name) {
  if (!idl_name.starts_with(kIdlModule)) return {};
  return idl_name.substr(kIdlModule.size());
}

std::string ros2_dds_type_name(std::string_view idl_name) {
  return std::string(kRos2Package) + "::msg::dds_::" + std::string(ros2_message_name(idl_name)) + "_";
}

}  // namespace rejuv::msgs
