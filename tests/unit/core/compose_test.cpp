// Composition of text-format files from fragments (kernel_sim/textproto "Composition"): repeated fields
// appended, singular fields overridden by the including file and refused when two fragments set them, every
// location in the fragment that wrote the field, and each bad include refused at its own line.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

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

// ---- What is not a text file of the expected kind (textproto.hpp "What is refused") ----

// A file a user may not read, named by a fragment they wrote (the loader runs as root): the refusal names the
// path and says why, and quotes none of the file.
constexpr std::string_view kShadowLike = "root:$y$j9T$secret:19000:0:99999:7:::\nbin:*:19000:0:99999:7:::\n";

void expect_nothing_quoted(const LoadError& e) {
  const std::string shown = e.to_string();
  EXPECT_EQ(shown.find("root"), std::string::npos) << shown;
  EXPECT_EQ(shown.find("secret"), std::string::npos) << shown;
  EXPECT_EQ(shown.find("j9T"), std::string::npos) << shown;
}

TEST_F(Compose, ShadowLikeInclude_RefusedAtTheIncludeLineByName_NothingQuoted) {
  const auto shadow = write("shadow", std::string(kShadowLike));
  const auto graph = write("graph.pbtxt", "name: \"g\"\ninclude: \"" + shadow.string() + "\"\n");
  proto::Launch g;
  const auto r = load_composed_textproto(graph, g);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), at("graph.pbtxt", 2, 1));
  EXPECT_NE(r.error().message.find("cannot include \"" + shadow.string() + "\""), std::string::npos)
      << r.error().message;
  EXPECT_NE(r.error().message.find("not a Launch file"), std::string::npos) << r.error().message;
  expect_nothing_quoted(r.error());
  EXPECT_EQ(g.ByteSizeLong(), 0U) << "nothing is half-loaded";

  proto::Policy p;  // the same through a policy's include
  const auto policy = write("policy.pbtxt", "name: \"p\"\ninclude: \"shadow\"\n");
  const auto rp = load_composed_textproto(policy, p);
  ASSERT_FALSE(rp.has_value());
  EXPECT_NE(rp.error().message.find("not a Policy file"), std::string::npos) << rp.error().message;
  expect_nothing_quoted(rp.error());
}

TEST_F(Compose, ShadowLikeFileNamedByTheUser_RefusedAsNotOfTheKind_NothingQuoted) {
  const auto shadow = write("shadow", std::string(kShadowLike));
  proto::Launch g;
  const auto r = load_composed_textproto(shadow, g);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), at("shadow", 1, 1));
  EXPECT_NE(r.error().message.find("not a Launch file"), std::string::npos) << r.error().message;
  expect_nothing_quoted(r.error());
}

// Past its first word an included file may still hold anything: its syntax errors are located, never quoted.
TEST_F(Compose, IncludedFileSyntaxError_LocatedButItsTextNotQuoted) {
  write("frag.pbtxt", "name: \"x\"\npassword: \"hunter2\"\n");
  const auto graph = write("graph.pbtxt", "include: \"frag.pbtxt\"\n");
  proto::Launch g;
  auto r = load_composed_textproto(graph, g);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Syntax);
  EXPECT_EQ(r.error().where.to_string(), at("frag.pbtxt", 2, 1));
  EXPECT_NE(r.error().message.find("no such field in rejuv.proto.Launch"), std::string::npos) << r.error().message;
  EXPECT_EQ(r.error().message.find("password"), std::string::npos) << r.error().message;

  write("frag.pbtxt", "name: \"x\"\nsr { t_mc_s: hunter2 }\n");
  r = load_composed_textproto(graph, g);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.line, 2);
  EXPECT_EQ(r.error().message.find("hunter2"), std::string::npos) << r.error().message;

  // The file the user named is theirs: its errors still quote the word at fault.
  const auto own = write("own.pbtxt", "name: \"x\"\npassword: \"hunter2\"\n");
  r = load_composed_textproto(own, g);
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("password"), std::string::npos) << r.error().message;
}

TEST_F(Compose, FifoIncludedOrNamed_RefusedWithoutWaitingForAWriter) {
  const auto fifo = dir_ / "fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0) << std::strerror(errno);
  const auto graph = write("graph.pbtxt", "name: \"g\"\ninclude: \"fifo\"\n");
  proto::Launch g;
  auto r = load_composed_textproto(graph, g);  // would block for ever in open(2) were the FIFO opened
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), at("graph.pbtxt", 2, 1));
  EXPECT_NE(r.error().message.find("not a regular file (a FIFO)"), std::string::npos) << r.error().message;

  r = load_composed_textproto(fifo, g);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::CannotRead);
  EXPECT_EQ(r.error().to_string(), fifo.string() + ":1:1: error: not a regular file (a FIFO)");
}

TEST_F(Compose, DirectoryOrDeviceIncluded_RefusedNamingWhatItIs) {
  proto::Policy p;
  auto r = load_composed_textproto(write("dir.pbtxt", "include: \"frag\"\n"), p);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), at("dir.pbtxt", 1, 1));
  EXPECT_NE(r.error().message.find("not a regular file (a directory)"), std::string::npos) << r.error().message;

  r = load_composed_textproto(write("dev.pbtxt", "include: \"/dev/zero\"\n"), p);
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("not a regular file (a character device)"), std::string::npos)
      << r.error().message;
}

TEST_F(Compose, BinaryFileIncludedOrNamed_RefusedAsNotText_NothingQuoted) {
  constexpr char kElf[] = "\x7f" "ELF\x02\x01\x01\x00secret\x00\x00";
  const std::string elf(kElf, sizeof kElf - 1);
  write("prog", elf);
  proto::Launch g;
  auto r = load_composed_textproto(write("graph.pbtxt", "include: \"prog\"\n"), g);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), at("graph.pbtxt", 1, 1));
  EXPECT_NE(r.error().message.find("not a text file (a control character at line 1, column 1)"), std::string::npos)
      << r.error().message;
  expect_nothing_quoted(r.error());

  r = load_composed_textproto(dir_ / "prog", g);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), at("prog", 1, 1));
  EXPECT_NE(r.error().message.find("not a text file"), std::string::npos) << r.error().message;

  constexpr char kNul[] = "name: \"g\"\nservices { name: \"a\0\" }\n";
  write("nul.pbtxt", std::string(kNul, sizeof kNul - 1));
  r = load_composed_textproto(dir_ / "nul.pbtxt", g);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), at("nul.pbtxt", 2, 20));
  EXPECT_NE(r.error().message.find("a NUL byte"), std::string::npos) << r.error().message;

  write("latin1.pbtxt", "name: \"caf\xe9\"\n");  // ISO 8859-1, not UTF-8
  r = load_composed_textproto(dir_ / "latin1.pbtxt", g);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), at("latin1.pbtxt", 1, 11));
  EXPECT_NE(r.error().message.find("not UTF-8"), std::string::npos) << r.error().message;

  write("utf8.pbtxt", "name: \"caf\xc3\xa9\"  # \xe2\x9c\x93\n");  // UTF-8 text is text
  EXPECT_TRUE(load_composed_textproto(dir_ / "utf8.pbtxt", g).has_value());
}

TEST_F(Compose, FileOverTheBound_RefusedBeforeItIsRead) {
  write("big.pbtxt", "name: \"g\"\n" + std::string(kMaxTextprotoBytes, ' '));
  proto::Launch g;
  auto r = load_composed_textproto(write("graph.pbtxt", "include: \"big.pbtxt\"\n"), g);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().where.to_string(), at("graph.pbtxt", 1, 1));
  EXPECT_NE(r.error().message.find("larger than " + std::to_string(kMaxTextprotoBytes)), std::string::npos)
      << r.error().message;
}

TEST_F(Compose, EmptyOrCommentOnlyFragment_IsAFragmentOfAnyKind) {
  write("empty.pbtxt", "");
  write("comment.pbtxt", "# nothing yet\n\n");
  proto::Launch g;
  const auto r = load_composed_textproto(
      write("graph.pbtxt", "include: \"empty.pbtxt\"\ninclude: \"comment.pbtxt\"\nname: \"g\"\n"), g);
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  EXPECT_EQ(g.name(), "g");
}

}  // namespace
}  // namespace rejuv
