#include "rejuv/ulog/topics.hpp"

#include <cstdint>
#include <string>
#include <type_traits>

#include "idl_fields.hpp"
#include "rejuv/msgs/topic_types.hpp"

namespace rejuv::ulog {
namespace {

template <class T>
concept IdlStruct = requires { msgs::IdlFields<T>::idl_name; };

// The ULog basic type of a C scalar (an IDL enum is a C enum: its size and signedness decide).
template <class T>
constexpr std::string_view basic_name() {
  if constexpr (std::is_enum_v<T>) {
    return basic_name<std::underlying_type_t<T>>();
  } else if constexpr (std::is_same_v<T, bool>) {
    return "bool";
  } else if constexpr (std::is_same_v<T, char>) {
    return "char";
  } else if constexpr (std::is_same_v<T, float>) {
    return "float";
  } else if constexpr (std::is_same_v<T, double>) {
    return "double";
  } else if constexpr (std::is_integral_v<T>) {
    constexpr bool s = std::is_signed_v<T>;
    if constexpr (sizeof(T) == 1) return s ? "int8_t" : "uint8_t";
    if constexpr (sizeof(T) == 2) return s ? "int16_t" : "uint16_t";
    if constexpr (sizeof(T) == 4) return s ? "int32_t" : "uint32_t";
    if constexpr (sizeof(T) == 8) return s ? "int64_t" : "uint64_t";
  } else {
    static_assert(sizeof(T) == 0, "an IDL member type the ULog formats do not handle");
  }
}

template <class T>
void flatten(const std::string& prefix, std::size_t base, std::vector<FieldAt>& out);

template <class M>
void flatten_member(const std::string& name, std::size_t offset, std::vector<FieldAt>& out) {
  using E = std::remove_all_extents_t<M>;
  constexpr std::size_t count = sizeof(M) / sizeof(E);
  if constexpr (IdlStruct<E>) {
    if constexpr (std::is_array_v<M>) {
      for (std::size_t i = 0; i < count; ++i) flatten<E>(name + "_" + std::to_string(i) + ".", offset + i * sizeof(E), out);
    } else {
      flatten<E>(name + ".", offset, out);
    }
  } else {
    out.push_back(FieldAt{.field = Field{.type = std::string(basic_name<E>()), .name = name,
                                         .array = std::is_array_v<M> ? static_cast<std::uint32_t>(count) : 0},
                          .offset = offset});
  }
}

template <class T>
void flatten(const std::string& prefix, std::size_t base, std::vector<FieldAt>& out) {
  msgs::IdlFields<T>::each([&]<class C, class M>(std::string_view name, M C::*, std::size_t offset) {
    flatten_member<M>(prefix + std::string(name), base + offset, out);
  });
}

// Padding fields wherever the members leave a gap, up to `size`.
std::vector<FieldAt> with_padding(std::vector<FieldAt> members, std::size_t size) {
  std::vector<FieldAt> out;
  std::size_t cursor = 0;
  int pad = 0;
  const auto gap = [&](std::size_t to) {
    if (to > cursor) {
      out.push_back(FieldAt{.field = Field{.type = "uint8_t", .name = "_padding" + std::to_string(pad++),
                                           .array = static_cast<std::uint32_t>(to - cursor)},
                            .offset = cursor});
    }
  };
  for (FieldAt& m : members) {
    gap(m.offset);
    cursor = m.offset + basic_size(m.field.type) * (m.field.array == 0 ? 1 : m.field.array);
    out.push_back(std::move(m));
  }
  gap(size);
  return out;
}

template <class T>
TopicLayout layout_of(std::string_view idl_name) {
  static_assert(std::is_standard_layout_v<T>);
  std::vector<FieldAt> members;
  flatten<T>("", 0, members);
  REJUV_ASSERT(msgs::IdlFields<T>::idl_name == idl_name, "IdlFields and REJUV_TOPIC_TYPES disagree on a name");
  return TopicLayout{.idl_name = idl_name, .size = sizeof(T), .members = with_padding(std::move(members), sizeof(T))};
}

std::vector<TopicLayout> make_layouts() {
  std::vector<TopicLayout> all;
#define REJUV_ULOG_LAYOUT(CType, Name) all.push_back(layout_of<CType>(Name));
  REJUV_TOPIC_TYPES(REJUV_ULOG_LAYOUT)
#undef REJUV_ULOG_LAYOUT
  return all;
}

}  // namespace

std::span<const TopicLayout> topic_layouts() {
  static const std::vector<TopicLayout> layouts = make_layouts();
  return layouts;
}

const TopicLayout* find_layout(std::string_view idl_name) {
  for (const TopicLayout& l : topic_layouts()) {
    if (l.idl_name == idl_name) return &l;
  }
  return nullptr;
}

Format topic_format(std::string_view format_name, const TopicLayout& layout) {
  Format f{.name = std::string(format_name), .fields = {Field{.type = "uint64_t", .name = "timestamp"}}};
  for (const FieldAt& m : layout.members) f.fields.push_back(m.field);
  return f;
}

Format raw_format(std::string_view format_name, std::size_t size) {
  return Format{.name = std::string(format_name),
                .fields = {Field{.type = "uint64_t", .name = "timestamp"},
                           Field{.type = "uint8_t", .name = "data", .array = static_cast<std::uint32_t>(size)}}};
}

}  // namespace rejuv::ulog
