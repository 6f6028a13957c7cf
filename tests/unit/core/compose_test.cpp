// Composition of text-format files from fragments (kernel_sim/textproto "Composition"): repeated fields
// appended, singular fields overridden by the including file and refused when two fragments set them, every
// location in the fragment that wrote the field, and each bad include refused at its own line.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "launch.pb.h"
#include "policy.pb.h"
#include "rejuv/textproto/textproto.hpp"

namespace rejuv {
namespace {

class Compose : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("rejuv_compose_" + std::to_string(::getpid()) + "_" +
                                                     ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_ / "frag");
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::filesystem::path write(const std::string& name, const std::string& text) const {
    const std::filesystem::path p = dir_ / name;
    std::ofstream(p) << text;
    return p;
  }
  std::string at(const std::string& name, int line, int column) const {
    return (dir_ / name).string() + ":" + std::to_string(line) + ":" + std::to_string(column);
  }

  std::filesystem::path dir_;
};

TEST_F(Compose, Fragments_AppendRepeatedFields_EachLocatedInItsOwnFile) {
  write("frag/a.pbtxt", "services { name: \"a\" }\nobjects { name: \"x\" kind: TOPIC }\n");
  write("frag/b.pbtxt", "\nservices { name: \"b\" }\n");
  const auto root = write("root.pbtxt", "name: \"p\"\ninclude: \"frag/a.pbtxt\"\ninclude: \"frag/b.pbtxt\"\n"
                                        "services { name: \"r\" }\n");
  proto::Policy p;
  const auto locs = load_composed_textproto(root, p);
  ASSERT_TRUE(locs.has_value()) << locs.error().to_string();
  ASSERT_EQ(p.services_size(), 3);
  EXPECT_EQ(p.services(0).name(), "a");
  EXPECT_EQ(p.services(1).name(), "b");
  EXPECT_EQ(p.services(2).name(), "r");
  EXPECT_EQ(p.include_size(), 0) << "the includes are composed, not left for a reader to skip";
  EXPECT_EQ(locs->locate({{"services", 0}}, "name").to_string(), at("frag/a.pbtxt", 1, 12));
  EXPECT_EQ(locs->locate({{"services", 1}}, "name").to_string(), at("frag/b.pbtxt", 2, 12));
  EXPECT_EQ(locs->locate({{"services", 2}}, "name").to_string(), at("root.pbtxt", 4, 12));
  EXPECT_EQ(locs->locate({{"objects", 0}}, "kind").to_string(), at("frag/a.pbtxt", 2, 21));
  EXPECT_EQ(locs->locate({}, "name").to_string(), at("root.pbtxt", 1, 1));
  EXPECT_EQ(locs->file(), root.string());
  EXPECT_EQ(locs->files().size(), 3U);
}

TEST_F(Compose, NestedFragments_PathsRelativeToTheIncludingFile) {
  write("frag/inner.pbtxt", "services { name: \"inner\" }\n");
  write("frag/outer.pbtxt", "include: \"inner.pbtxt\"\nservices { name: \"outer\" }\n");
  const auto root = write("root.pbtxt", "include: \"frag/outer.pbtxt\"\n");
  proto::Policy p;
  const auto locs = load_composed_textproto(root, p);
  ASSERT_TRUE(locs.has_value()) << locs.error().to_string();
  ASSERT_EQ(p.services_size(), 2);
  EXPECT_EQ(p.services(0).name(), "inner");
  EXPECT_EQ(locs->locate({{"services", 0}}, "name").file, (dir_ / "frag/inner.pbtxt").string());
  EXPECT_EQ(locs->locate({{"services", 1}}, "name").file, (dir_ / "frag/outer.pbtxt").string());
}

TEST_F(Compose, SingularFields_MergedByField_TheIncludingFileOverrides) {
  write("base.pbtxt", "name: \"base\"\nseed: 7\nsr {\n  enabled: true\n  t_mc_s: 0.3\n}\n"
                      "dds { bridges { topic: \"a\" } }\n");
  const auto root = write("root.pbtxt", "include: \"base.pbtxt\"\nname: \"mine\"\nsr { enabled: false t_est_s: 1 }\n"
                                        "dds { bridges { topic: \"b\" } }\n");
  proto::Launch g;
  const auto locs = load_composed_textproto(root, g);
  ASSERT_TRUE(locs.has_value()) << locs.error().to_string();
  EXPECT_EQ(g.name(), "mine");
  EXPECT_EQ(g.seed(), 7U);
  EXPECT_FALSE(g.sr().enabled()) << "an explicit false in the including file overrides the fragment's true";
  EXPECT_DOUBLE_EQ(g.sr().t_mc_s(), 0.3);
  EXPECT_DOUBLE_EQ(g.sr().t_est_s(), 1.0);
  ASSERT_EQ(g.dds().bridges_size(), 2);
  EXPECT_EQ(locs->locate({}, "name").to_string(), at("root.pbtxt", 2, 1));
  EXPECT_EQ(locs->locate({{"sr", -1}}, "enabled").to_string(), at("root.pbtxt", 3, 6));
  EXPECT_EQ(locs->locate({{"sr", -1}}, "t_mc_s").to_string(), at("base.pbtxt", 5, 3));
  EXPECT_EQ(locs->locate({{"dds", -1}, {"bridges", 0}}, "topic").file, (dir_ / "base.pbtxt").string());
  EXPECT_EQ(locs->locate({{"dds", -1}, {"bridges", 1}}, "topic").file, root.string());
}

TEST_F(Compose, TwoFragmentsSettingOneField_RefusedAtTheSecondNamingTheFirst) {
  write("a.pbtxt", "sr { t_mc_s: 0.3 }\n");
  write("b.pbtxt", "\nsr {\n  t_mc_s: 0.5\n}\n");
  const auto root = write("root.pbtxt", "include: \"a.pbtxt\"\ninclude: \"b.pbtxt\"\n");
  proto::Launch g;
  const auto r = load_composed_textproto(root, g);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), at("b.pbtxt", 3, 3));
  EXPECT_NE(r.error().message.find("`sr.t_mc_s`"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find(at("a.pbtxt", 1, 6)), std::string::npos) << r.error().message;
}

TEST_F(Compose, BadIncludes_RefusedAtTheIncludeLine) {
  const auto missing = write("missing.pbtxt", "name: \"p\"\ninclude: \"nope.pbtxt\"\n");
  proto::Policy p;
  auto r = load_composed_textproto(missing, p);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), at("missing.pbtxt", 2, 1));
  EXPECT_NE(r.error().message.find("cannot include"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("no such file"), std::string::npos) << r.error().message;

  write("frag/loop.pbtxt", "include: \"../cycle.pbtxt\"\n");
  const auto cycle = write("cycle.pbtxt", "include: \"frag/loop.pbtxt\"\n");
  r = load_composed_textproto(cycle, p);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), at("frag/loop.pbtxt", 1, 1));
  EXPECT_NE(r.error().message.find("include cycle"), std::string::npos) << r.error().message;

  write("once.pbtxt", "services { name: \"o\" }\n");
  const auto twice = write("twice.pbtxt", "include: \"once.pbtxt\"\ninclude: \"./frag/../once.pbtxt\"\n");
  r = load_composed_textproto(twice, p);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), at("twice.pbtxt", 2, 1));
  EXPECT_NE(r.error().message.find("already included"), std::string::npos) << r.error().message;

  write("bad.pbtxt", "services { name: \"o\" }\nbogus: 1\n");
  const auto syntax = write("syntax.pbtxt", "include: \"bad.pbtxt\"\n");
  r = load_composed_textproto(syntax, p);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Syntax);
  EXPECT_EQ(r.error().where.to_string(), at("bad.pbtxt", 2, 1)) << "a fragment's own error is at its own line";
  EXPECT_EQ(p.services_size(), 0) << "nothing is half-loaded";
}

TEST_F(Compose, EndlessFileOfReportedSizeZero_RefusedNotReadToTheEnd) {
  // /proc/self/pagemap says 0 bytes and reads on for gigabytes: an include of it is refused at its bound.
  const auto root = write("proc.pbtxt", "include: \"/proc/self/pagemap\"\n");
  proto::Policy p;
  const auto r = load_composed_textproto(root, p);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), at("proc.pbtxt", 1, 1));
  EXPECT_NE(r.error().message.find("larger than"), std::string::npos) << r.error().message;
}

TEST_F(Compose, DeepChain_RefusedPastTheDepthLimit) {
  for (int i = 0; i <= kMaxIncludeDepth + 1; ++i) {
    write("d" + std::to_string(i) + ".pbtxt", "include: \"d" + std::to_string(i + 1) + ".pbtxt\"\n");
  }
  proto::Policy p;
  const auto r = load_composed_textproto(dir_ / "d0.pbtxt", p);
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("nest deeper"), std::string::npos) << r.error().to_string();
}

TEST_F(Compose, ExtraFragments_MergedAsIfIncludedFirst) {
  const auto extra = write("frag/grants.pbtxt", "grants { service: \"a\" object: \"x\" rights: \"R\" modes: MC }\n");
  const auto root = write("root.pbtxt", "name: \"p\"\ngrants { service: \"b\" object: \"x\" rights: \"R\" modes: MC }\n");
  proto::Policy p;
  const ExtraFragment fragments[] = {{extra, SourceLocation{"graph.launch.pbtxt", 9, 1}}};
  const auto locs = load_composed_textproto(root, p, fragments);
  ASSERT_TRUE(locs.has_value()) << locs.error().to_string();
  ASSERT_EQ(p.grants_size(), 2);
  EXPECT_EQ(p.grants(0).service(), "a");
  EXPECT_EQ(locs->locate({{"grants", 0}}, "service").file, extra.string());

  const ExtraFragment missing[] = {{dir_ / "none.pbtxt", SourceLocation{"graph.launch.pbtxt", 9, 3}}};
  const auto r = load_composed_textproto(root, p, missing);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), "graph.launch.pbtxt:9:3") << "refused where the launch graph named it";
}

}  // namespace
}  // namespace rejuv
