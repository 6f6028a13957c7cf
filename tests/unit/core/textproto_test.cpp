#include <gtest/gtest.h>

#include <filesystem>

#include "policy.pb.h"
#include "rejuv/textproto/textproto.hpp"

namespace rejuv {
namespace {

TEST(Textproto, Parse_ValidPolicy_RecordsFieldLocations) {
  proto::Policy p;
  const auto locs = parse_textproto("name: \"p\"\nservices {\n  name: \"a\"\n}\nservices { name: \"b\" }\n",
                                    "mem.pbtxt", p);
  ASSERT_TRUE(locs.has_value()) << locs.error().to_string();
  ASSERT_EQ(p.services_size(), 2);
  const SourceLocation where = locs->locate({{"services", 1}}, "name");
  EXPECT_EQ(where.to_string(), "mem.pbtxt:5:12");
  EXPECT_EQ(locs->locate({{"services", 0}}, "name").line, 3);
}

TEST(Textproto, Parse_UnknownField_SyntaxErrorWithLineAndColumn) {
  proto::Policy p;
  const auto r = parse_textproto("name: \"p\"\n  bogus: 1\n", "bad.pbtxt", p);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Syntax);
  EXPECT_EQ(r.error().where.line, 2);
  EXPECT_EQ(r.error().where.column, 3);
  EXPECT_NE(r.error().message.find("bogus"), std::string::npos) << r.error().message;
}

TEST(Textproto, Parse_UnknownEnumValue_SyntaxError) {
  proto::Policy p;
  const auto r = parse_textproto("grants { modes: XX }\n", "bad.pbtxt", p);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.line, 1);
  EXPECT_NE(r.error().to_string().find("bad.pbtxt:1:"), std::string::npos);
}

TEST(Textproto, Parse_DuplicateSingularField_Refused) {
  proto::Policy p;
  const auto r = parse_textproto("name: \"a\"\nname: \"b\"\n", "dup.pbtxt", p);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.line, 2);
}

TEST(Textproto, Load_MissingFile_CannotRead) {
  proto::Policy p;
  const auto r = load_textproto("/nonexistent/rejuv.pbtxt", p);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::CannotRead);
}

TEST(Textproto, Load_Directory_CannotRead) {
  proto::Policy p;
  const auto r = load_textproto(std::filesystem::temp_directory_path(), p);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::CannotRead);
}

TEST(Textproto, Parse_Garbage_NeverCrashes) {
  proto::Policy p;
  const std::string inputs[] = {"{", "}", "services {", "\"", "name: ", std::string(3, '\0'), "\xff\xfe"};
  for (const std::string& in : inputs) {
    EXPECT_FALSE(parse_textproto(in, "g.pbtxt", p).has_value()) << in;
  }
}

}  // namespace
}  // namespace rejuv
