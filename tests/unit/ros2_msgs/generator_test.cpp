// The restricted IDL parser and the rejuv_msgs generator (tools/ros2_msgs): the mapping of each IDL construct
// it reads, the project's own IDL, and a precise refusal (file:line:column, what was found) of each it does
// not. That Debian's rosidl parser accepts the generated package and a ROS 2 reader decodes Cyclone's samples
// with it: tests/ros2_msgs.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "rejuv/msgs/dds_naming.hpp"
#include "rejuv/msgs/topic_types.hpp"
#include "rejuv/ros2_msgs/idl.hpp"
#include "rejuv/ros2_msgs/package.hpp"

namespace rejuv::ros2_msgs {
namespace {

Result<std::string, IdlError> message_of(const std::string& idl, const std::string& scoped) {
  Definitions defs;
  if (auto ok = parse_idl(idl, "t.idl", defs); !ok) return fail(ok.error());
  const Struct* s = defs.find_struct(scoped);
  if (s == nullptr) return fail(IdlError{.at = {}, .message = "no struct " + scoped});
  return make_message(defs, *s);
}

// The error of parsing and generating `idl`, or "" when both succeed.
std::string error_of(const std::string& idl) {
  Definitions defs;
  if (auto ok = parse_idl(idl, "t.idl", defs); !ok) return ok.error().to_string();
  auto files = make_package(defs, "0.1.0");
  return files ? std::string() : files.error().to_string();
}

// The lines of a .msg that are not comments or blank: what rosidl reads.
std::vector<std::string> code_lines(const std::string& msg) {
  std::vector<std::string> out;
  std::istringstream in(msg);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    const std::size_t hash = line.find("  #");
    out.push_back(hash == std::string::npos ? line : line.substr(0, hash));
  }
  return out;
}

TEST(Ros2MsgsGenerator, EveryPrimitiveSpelling_MapsToItsRos2Type) {
  const auto msg = message_of(R"(module m {
@final struct All {
  boolean a; char b; octet c; int8 d; uint8 e; int16 f; uint16 g; int32 h; uint32 i; int64 j; uint64 k;
  float l; double n; short o; unsigned short p; long q; unsigned long r; long long s; unsigned long long t;
};
};)", "m::All");
  ASSERT_TRUE(msg.has_value()) << msg.error().to_string();
  EXPECT_EQ(code_lines(*msg),
            (std::vector<std::string>{"bool a", "char b", "uint8 c", "int8 d", "uint8 e", "int16 f", "uint16 g",
                                      "int32 h", "uint32 i", "int64 j", "uint64 k", "float32 l", "float64 n",
                                      "int16 o", "uint16 p", "int32 q", "uint32 r", "int64 s", "uint64 t"}));
}

TEST(Ros2MsgsGenerator, ArraysNestedStructsEnums_AsRos2WritesThem) {
  const auto msg = message_of(R"(module rejuv { module msg {
enum Mode { MODE_A, MODE_B };
// A point.
@final struct P { double xyz_m[3]; };
// Several points.
@final struct Many {
  ::rejuv::msg::P points[4];   // up to four
  msg::P one;
  Mode mode;                   // what it is
  uint8 count;
};
}; };)", "rejuv::msg::Many");
  ASSERT_TRUE(msg.has_value()) << msg.error().to_string();
  EXPECT_EQ(code_lines(*msg), (std::vector<std::string>{"uint32 MODE_A=0", "uint32 MODE_B=1", "P[4] points", "P one",
                                                        "uint32 mode", "uint8 count"}));
  EXPECT_NE(msg->find("# Several points."), std::string::npos) << *msg;
  EXPECT_NE(msg->find("P[4] points  # up to four"), std::string::npos) << *msg;
  EXPECT_NE(msg->find("uint32 mode  # rejuv::msg::Mode; what it is"), std::string::npos) << *msg;
}

TEST(Ros2MsgsGenerator, CapitalsInMemberNames_LowerCaseWithTheIdlNameInTheComment) {
  const auto msg = message_of("module m { @final struct S { double thrust_N;  // F [N]\n}; };", "m::S");
  ASSERT_TRUE(msg.has_value()) << msg.error().to_string();
  EXPECT_NE(msg->find("float64 thrust_n  # IDL thrust_N: F [N]"), std::string::npos) << *msg;
}

TEST(Ros2MsgsGenerator, ContinuedMemberComment_Joined) {
  const auto msg = message_of("module m { @final struct S {\n  uint32 flags;  // bit 0 a,\n                 // bit 1 b\n}; };",
                              "m::S");
  ASSERT_TRUE(msg.has_value()) << msg.error().to_string();
  EXPECT_NE(msg->find("uint32 flags  # bit 0 a, bit 1 b"), std::string::npos) << *msg;
}

TEST(Ros2MsgsGenerator, Package_Format3InterfacePackageListingEveryMessage) {
  Definitions defs;
  ASSERT_TRUE(parse_idl("module m { @final struct A { int32 x; }; @final struct B { m::A a; }; };", "t.idl", defs));
  auto files = make_package(defs, "1.2.3");
  ASSERT_TRUE(files.has_value()) << files.error().to_string();
  ASSERT_EQ(files->size(), 4u);
  EXPECT_EQ((*files)[0].path, "msg/A.msg");
  EXPECT_EQ((*files)[1].path, "msg/B.msg");
  EXPECT_EQ((*files)[2].path, "package.xml");
  EXPECT_EQ((*files)[3].path, "CMakeLists.txt");
  const std::string& xml = (*files)[2].text;
  EXPECT_NE(xml.find("<package format=\"3\">"), std::string::npos);
  EXPECT_NE(xml.find("<name>rejuv_msgs</name>"), std::string::npos);
  EXPECT_NE(xml.find("<version>1.2.3</version>"), std::string::npos);
  EXPECT_NE(xml.find("<member_of_group>rosidl_interface_packages</member_of_group>"), std::string::npos);
  EXPECT_NE(xml.find("<buildtool_depend>rosidl_default_generators</buildtool_depend>"), std::string::npos);
  EXPECT_NE(xml.find("<exec_depend>rosidl_default_runtime</exec_depend>"), std::string::npos);
  const std::string& cmake = (*files)[3].text;
  EXPECT_NE(cmake.find("rosidl_generate_interfaces(${PROJECT_NAME}\n  \"msg/A.msg\"\n  \"msg/B.msg\"\n)"),
            std::string::npos)
      << cmake;
}

// The project's IDL: every topic type has its message, named as the ROS 2 DDS type name says, with one field
// per member.
TEST(Ros2MsgsGenerator, ProjectIdl_AMessagePerTopicType) {
  std::vector<std::filesystem::path> files;
  for (const char* f : {"sensors.idl", "state.idl", "control.idl", "sr.idl", "sim.idl"}) {
    files.push_back(std::filesystem::path(REJUV_SOURCE_DIR) / "idl" / f);
  }
  auto defs = load_idl(files);
  ASSERT_TRUE(defs.has_value()) << defs.error().to_string();
  for (const msgs::TopicType& t : msgs::all_topic_types()) {
    const Struct* s = defs->find_struct(t.name);
    ASSERT_NE(s, nullptr) << t.name;
    EXPECT_EQ(s->name, msgs::ros2_message_name(t.name));
    auto msg = make_message(*defs, *s);
    ASSERT_TRUE(msg.has_value()) << msg.error().to_string();
    std::size_t fields = 0;
    for (const std::string& line : code_lines(*msg)) fields += line.find('=') == std::string::npos ? 1 : 0;
    EXPECT_EQ(fields, s->members.size()) << t.name;
  }
  ASSERT_NE(defs->find_struct("rejuv::msg::Waypoint"), nullptr) << "a nested struct has its message too";
}

// The package does not depend on the order of the IDL files.
TEST(Ros2MsgsGenerator, FileOrder_SamePackage) {
  const std::filesystem::path idl = std::filesystem::path(REJUV_SOURCE_DIR) / "idl";
  const std::vector<std::filesystem::path> one{idl / "sensors.idl", idl / "control.idl"};
  const std::vector<std::filesystem::path> other{idl / "control.idl", idl / "sensors.idl"};
  auto a = load_idl(one);
  auto b = load_idl(other);
  ASSERT_TRUE(a.has_value() && b.has_value());
  auto pa = make_package(*a, "0.1.0");
  auto pb = make_package(*b, "0.1.0");
  ASSERT_TRUE(pa.has_value() && pb.has_value());
  ASSERT_EQ(pa->size(), pb->size());
  for (std::size_t i = 0; i < pa->size(); ++i) {
    EXPECT_EQ((*pa)[i].path, (*pb)[i].path);
    EXPECT_EQ((*pa)[i].text, (*pb)[i].text) << (*pa)[i].path;
  }
}

// sim.idl names sensors.idl's structs: its #include is followed, relative to sim.idl, and read once.
TEST(Ros2MsgsGenerator, Include_FollowedOnce) {
  const std::filesystem::path idl = std::filesystem::path(REJUV_SOURCE_DIR) / "idl";
  const std::vector<std::filesystem::path> files{idl / "sim.idl", idl / "sensors.idl"};
  auto defs = load_idl(files);
  ASSERT_TRUE(defs.has_value()) << defs.error().to_string();
  EXPECT_NE(defs->find_struct("rejuv::msg::SimStep"), nullptr);
  EXPECT_NE(defs->find_struct("rejuv::msg::SensorGyro"), nullptr);
}

// ---- refusals: each at its place, saying what was found ----

struct Refusal {
  const char* name;     // the test's
  const char* idl;
  const char* at;       // "line:column"
  const char* message;  // a part of the message
};

class Ros2MsgsRefusal : public testing::TestWithParam<Refusal> {};

TEST_P(Ros2MsgsRefusal, PreciseError) {
  const Refusal& r = GetParam();
  const std::string e = error_of(r.idl);
  EXPECT_NE(e.find(std::string("t.idl:") + r.at + ": error: "), std::string::npos) << e;
  EXPECT_NE(e.find(r.message), std::string::npos) << e;
}

INSTANTIATE_TEST_SUITE_P(
    Generator, Ros2MsgsRefusal,
    testing::Values(
        Refusal{"Sequence", "module m {\n@final struct S {\n  sequence<double> x;\n};\n};", "3:3", "sequence<T> (a variable-length member) is not supported"},
        Refusal{"String", "module m { @final struct S { string name; }; };", "1:30", "string (a variable-length member) is not supported"},
        Refusal{"Union", "module m { union U switch (long) { case 1: long x; }; };", "1:12", "union is not supported"},
        Refusal{"Typedef", "module m { typedef double D; };", "1:12", "typedef is not supported"},
        Refusal{"Const", "module m { const long N = 3; };", "1:12", "const is not supported"},
        Refusal{"Appendable", "module m { @appendable struct S { long x; }; };", "1:12", "annotation @appendable is not supported"},
        Refusal{"MemberAnnotation", "module m { @final struct S { @key long id; }; };", "1:30", "annotations on members"},
        Refusal{"TwoDimensions", "module m { @final struct S { double m[3][3]; }; };", "1:41", "multi-dimensional arrays"},
        Refusal{"TwoDeclarators", "module m { @final struct S { double a, b; }; };", "1:38", "one member per declaration"},
        Refusal{"UnknownType", "module m { @final struct S { Missing x; }; };", "1:30", "unknown type 'Missing'"},
        Refusal{"MissingSemicolon", "module m { @final struct S { double x }; };", "1:39", "expected ';' after member x, found '}'"},
        Refusal{"ArraySizeZero", "module m { @final struct S { double x[0]; }; };", "1:39", "an array size is a decimal integer"},
        Refusal{"ArraySizeNotANumber", "module m { @final struct S { double x[N]; }; };", "1:39", "found 'N'"},
        Refusal{"LongDouble", "module m { @final struct S { long double x; }; };", "1:30", "long double is not supported"},
        Refusal{"EnumeratorValue", "module m { enum E { A = 1 }; };", "1:23", "enumerator values are not IDL"},
        Refusal{"Define", "#define X 1\nmodule m {};", "1:1", "preprocessor directive '#define X 1' is not supported"},
        Refusal{"UnterminatedComment", "module m { /* never closed", "1:12", "unterminated /* comment"},
        Refusal{"DuplicateStruct", "module m { @final struct S { long x; }; @final struct S { long y; }; };", "1:41", "'m::S' is declared twice"},
        Refusal{"FieldCollision", "module m { @final struct S { double p_N; double p_n; }; };", "1:42", "members 'p_N' and 'p_n' of m::S are both the ROS 2 field 'p_n'"},
        Refusal{"BadFieldName", "module m { @final struct S { double x_; }; };", "1:30", "member 'x_' of m::S has no ROS 2 field name"},
        Refusal{"BadMessageName", "module m { @final struct lower { double x; }; };", "1:12", "struct name 'lower' is not a ROS 2 message name"},
        Refusal{"BadConstantName", "module m { enum E { bad_name }; @final struct S { E e; }; };", "1:12", "enumerator 'bad_name' of m::E is not a ROS 2 constant name"},
        Refusal{"EmptyStruct", "module m { @final struct S { }; };", "1:30", "struct m::S has no members"},
        Refusal{"UnclosedModule", "module m { @final struct S { double x; };", "1:42", "expected '}' closing module m, found 'end of file'"},
        Refusal{"ExtraBrace", "module m { @final struct S { double x; }; }; }", "1:46", "unexpected '}': no module is open"},
        Refusal{"DirectiveInsideModule", "module m { #include \"x.idl\"\n};", "1:12", "unexpected character '#'"},
        Refusal{"MessageNameTwice", "module a { @final struct S { long x; }; }; module b { @final struct S { long y; }; };", "1:55",
                "struct b::S and a::S would both be the message rejuv_msgs/S"}),
    [](const testing::TestParamInfo<Refusal>& p) { return std::string(p.param.name); });

TEST(Ros2MsgsGenerator, IncludeOfAMissingFile_RefusedAtTheInclude) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("ros2_msgs_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  {
    std::ofstream(dir / "a.idl") << "// first line\n#include \"missing.idl\"\nmodule m { @final struct S { long x; }; };\n";
  }
  const std::vector<std::filesystem::path> files{dir / "a.idl"};
  auto defs = load_idl(files);
  std::filesystem::remove_all(dir);
  ASSERT_FALSE(defs.has_value());
  EXPECT_EQ(defs.error().at.line, 2);
  EXPECT_EQ(defs.error().at.column, 1);
  EXPECT_NE(defs.error().message.find("cannot read"), std::string::npos) << defs.error().to_string();
  EXPECT_NE(defs.error().message.find("missing.idl"), std::string::npos) << defs.error().to_string();
}

}  // namespace
}  // namespace rejuv::ros2_msgs
