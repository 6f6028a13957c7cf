// The ULog writer against the specification (docs.px4.io "ULog File Format"): the expected bytes of each
// message kind are written out by hand from the spec's structs, not produced by the code under test.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "rejuv/ulog/writer.hpp"

namespace rejuv::ulog {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes bytes_of(std::span<const std::byte> b) {
  Bytes out(b.size());
  std::memcpy(out.data(), b.data(), b.size());
  return out;
}
Bytes str(std::string_view s) { return Bytes(s.begin(), s.end()); }
Bytes cat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const Bytes& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}
constexpr std::size_t kPreamble = 16 + 3 + 40;  // header, flag bits

// The bytes written after the header and the flag bits.
Bytes tail(const Encoder& e, std::size_t from = kPreamble) {
  const Bytes all = bytes_of(e.bytes());
  return Bytes(all.begin() + static_cast<std::ptrdiff_t>(from), all.end());
}

// A message as the spec reads it: uint16 msg_size, uint8 msg_type, payload.
struct Message {
  char type;
  Bytes payload;
};
// Splits a whole file into its messages (the test's own reader, from the spec).
std::vector<Message> messages(const Bytes& file) {
  std::vector<Message> out;
  std::size_t at = 16;
  while (at + 3 <= file.size()) {
    const std::size_t size = file[at] | (file[at + 1] << 8);
    EXPECT_LE(at + 3 + size, file.size()) << "a message runs past the end of the file";
    out.push_back({static_cast<char>(file[at + 2]),
                   Bytes(file.begin() + static_cast<std::ptrdiff_t>(at + 3),
                         file.begin() + static_cast<std::ptrdiff_t>(std::min(file.size(), at + 3 + size)))});
    at += 3 + size;
  }
  EXPECT_EQ(at, file.size());
  return out;
}

Format one_double(std::string name) {
  return Format{.name = std::move(name), .fields = {{.type = "uint64_t", .name = "timestamp"},
                                                    {.type = "double", .name = "x"}}};
}

TEST(UlogEncoder, Header_IsMagicVersionAndStartTime) {
  const Encoder e(0x0102030405060708ULL);
  const Bytes all = bytes_of(e.bytes());
  ASSERT_GE(all.size(), 16u);
  EXPECT_EQ(Bytes(all.begin(), all.begin() + 16),
            (Bytes{0x55, 0x4C, 0x6F, 0x67, 0x01, 0x12, 0x35, 0x01, 0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01}));
}

TEST(UlogEncoder, FlagBits_FirstMessageAllZero) {
  const Encoder e(0);
  const Bytes all = bytes_of(e.bytes());
  ASSERT_EQ(all.size(), kPreamble);
  EXPECT_EQ(Bytes(all.begin() + 16, all.begin() + 19), (Bytes{40, 0, 'B'}));
  for (std::size_t i = 19; i < all.size(); ++i) EXPECT_EQ(all[i], 0) << i;
}

TEST(UlogEncoder, InfoString_KeyCarriesTheLength) {
  Encoder e(0);
  ASSERT_TRUE(e.info_string("sys_name", "Rejuv"));
  const Bytes key = str("char[5] sys_name");
  EXPECT_EQ(tail(e), cat({{static_cast<std::uint8_t>(1 + key.size() + 5), 0, 'I', static_cast<std::uint8_t>(key.size())},
                          key, str("Rejuv")}));
}

TEST(UlogEncoder, InfoU64_LittleEndianValue) {
  Encoder e(0);
  ASSERT_TRUE(e.info_u64("seed", 258));
  const Bytes key = str("uint64_t seed");
  EXPECT_EQ(tail(e), cat({{static_cast<std::uint8_t>(1 + key.size() + 8), 0, 'I', static_cast<std::uint8_t>(key.size())},
                          key, {2, 1, 0, 0, 0, 0, 0, 0}}));
}

TEST(UlogEncoder, ParameterFloat_KeyAndIeeeValue) {
  Encoder e(0);
  ASSERT_TRUE(e.parameter("sr.t_mc_s", 0.5F));  // 0.5f = 0x3F000000
  const Bytes key = str("float sr.t_mc_s");
  EXPECT_EQ(tail(e), cat({{static_cast<std::uint8_t>(1 + key.size() + 4), 0, 'P', static_cast<std::uint8_t>(key.size())},
                          key, {0x00, 0x00, 0x00, 0x3F}}));
}

TEST(UlogEncoder, ParameterInt32_KeyAndValue) {
  Encoder e(0);
  ASSERT_TRUE(e.parameter("sr.enabled", std::int32_t{-2}));
  const Bytes key = str("int32_t sr.enabled");
  EXPECT_EQ(tail(e), cat({{static_cast<std::uint8_t>(1 + key.size() + 4), 0, 'P', static_cast<std::uint8_t>(key.size())},
                          key, {0xFE, 0xFF, 0xFF, 0xFF}}));
}

TEST(UlogEncoder, Format_NameColonFieldsSemicolons) {
  Encoder e(0);
  const Format f{.name = "gyro", .fields = {{.type = "uint64_t", .name = "timestamp"},
                                            {.type = "double", .name = "w", .array = 3},
                                            {.type = "uint8_t", .name = "_padding0", .array = 7}}};
  ASSERT_TRUE(e.format(f));
  const Bytes text = str("gyro:uint64_t timestamp;double[3] w;uint8_t[7] _padding0;");
  EXPECT_EQ(tail(e), cat({{static_cast<std::uint8_t>(text.size()), 0, 'F'}, text}));
  EXPECT_EQ(e.format_size("gyro"), 8u + 24u + 7u);
}

TEST(UlogEncoder, Format_NestedTypeSizedFromItsFormat) {
  Encoder e(0);
  ASSERT_TRUE(e.format(Format{.name = "inner", .fields = {{.type = "uint64_t", .name = "timestamp"}}}));
  ASSERT_TRUE(e.format(Format{.name = "outer", .fields = {{.type = "inner", .name = "a", .array = 2}}}));
  EXPECT_EQ(e.format_size("outer"), 16u);
}

TEST(UlogEncoder, AddLoggedAndData_Layout) {
  Encoder e(0);
  ASSERT_TRUE(e.format(one_double("pos")));
  const auto id = e.add_logged("pos", 3);
  ASSERT_TRUE(id);
  EXPECT_EQ(*id, 0);
  const auto id2 = e.add_logged("pos", 4);
  ASSERT_TRUE(id2);
  EXPECT_EQ(*id2, 1);
  std::array<std::uint8_t, 16> payload{};
  payload[0] = 0xAA;
  payload[15] = 0xBB;
  const std::size_t before = bytes_of(e.bytes()).size();
  ASSERT_TRUE(e.data(1, std::as_bytes(std::span(payload))));
  const Bytes a = str("pos");
  const Bytes all = bytes_of(e.bytes());
  const std::size_t format_end = kPreamble + 3 + str(format_text(one_double("pos"))).size();
  EXPECT_EQ(Bytes(all.begin() + static_cast<std::ptrdiff_t>(format_end), all.begin() + static_cast<std::ptrdiff_t>(before)),
            cat({{static_cast<std::uint8_t>(3 + a.size()), 0, 'A', 3, 0, 0}, a,
                 {static_cast<std::uint8_t>(3 + a.size()), 0, 'A', 4, 1, 0}, a}));
  EXPECT_EQ(tail(e, before), cat({{18, 0, 'D', 1, 0}, Bytes(payload.begin(), payload.end())}));
}

TEST(UlogEncoder, Log_LevelDigitTimestampText) {
  Encoder e(0);
  e.log(LogLevel::Warning, 0x1122334455667788ULL, "rollback to g3");
  const Bytes text = str("rollback to g3");
  EXPECT_EQ(tail(e), cat({{static_cast<std::uint8_t>(9 + text.size()), 0, 'L', '4',
                           0x88, 0x77, 0x66, 0x55, 0x44, 0x33, 0x22, 0x11}, text}));
}

TEST(UlogEncoder, Sync_Magic) {
  Encoder e(0);
  e.sync();
  EXPECT_EQ(tail(e), (Bytes{8, 0, 'S', 0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12}));
}

TEST(UlogEncoder, DefinitionAfterData_Refused) {
  Encoder e(0);
  ASSERT_TRUE(e.format(one_double("a")));
  ASSERT_TRUE(e.add_logged("a"));
  EXPECT_EQ(e.format(one_double("b")).error(), UlogError::NotADefinition);
  EXPECT_EQ(e.info_string("k", "v").error(), UlogError::NotADefinition);
  EXPECT_TRUE(e.parameter("p", 1.0F)) << "a parameter may change in the data section";
}

TEST(UlogEncoder, DataOfWrongSize_Refused) {
  Encoder e(0);
  ASSERT_TRUE(e.format(one_double("a")));
  const auto id = e.add_logged("a");
  ASSERT_TRUE(id);
  std::array<std::byte, 15> short_payload{};
  EXPECT_EQ(e.data(*id, short_payload).error(), UlogError::WrongSize);
}

TEST(UlogEncoder, DataOfUnknownMsgId_Refused) {
  Encoder e(0);
  std::array<std::byte, 16> payload{};
  EXPECT_EQ(e.data(0, payload).error(), UlogError::UnknownMsgId);
}

TEST(UlogEncoder, AddLoggedOfUnknownFormat_Refused) {
  Encoder e(0);
  EXPECT_EQ(e.add_logged("nothing").error(), UlogError::UnknownFormat);
}

TEST(UlogEncoder, DuplicateFormat_Refused) {
  Encoder e(0);
  ASSERT_TRUE(e.format(one_double("a")));
  EXPECT_EQ(e.format(one_double("a")).error(), UlogError::DuplicateFormat);
}

TEST(UlogEncoder, FieldOfUnknownType_Refused) {
  Encoder e(0);
  EXPECT_EQ(e.format(Format{.name = "a", .fields = {{.type = "vec3", .name = "v"}}}).error(), UlogError::UnknownType);
}

TEST(UlogEncoder, NamesThatBreakTheSyntax_Refused) {
  Encoder e(0);
  EXPECT_EQ(e.format(one_double("a:b")).error(), UlogError::BadName);
  EXPECT_EQ(e.format(Format{.name = "a", .fields = {{.type = "double", .name = "x y"}}}).error(), UlogError::BadName);
  EXPECT_EQ(e.parameter("", 1.0F).error(), UlogError::BadName);
  EXPECT_EQ(e.info_string("a;b", "v").error(), UlogError::BadName);
}

TEST(UlogEncoder, KeyLongerThan255_Refused) {
  Encoder e(0);
  EXPECT_EQ(e.parameter(std::string(250, 'k'), 1.0F).error(), UlogError::TooLong);
  EXPECT_TRUE(e.parameter(std::string(249, 'k'), 1.0F)) << "\"float \" + 249 = 255 bytes";
}

TEST(UlogEncoder, LongLogLine_CutAtAUtf8Boundary) {
  Encoder e(0);
  std::string text;
  for (int i = 0; i < 40000; ++i) text += "\xC3\xA9";  // é, 80000 bytes
  e.log(LogLevel::Info, 7, text);
  const std::vector<Message> m = messages(bytes_of(e.bytes()));
  ASSERT_EQ(m.size(), 2u);
  ASSERT_EQ(m[1].type, 'L');
  const std::size_t text_bytes = m[1].payload.size() - 9;
  EXPECT_LE(m[1].payload.size(), kMaxPayload);
  EXPECT_EQ(text_bytes % 2, 0u) << "a cut inside a two-byte character";
  EXPECT_GE(text_bytes, kMaxPayload - 9 - 1);
}

TEST(UlogEncoder, LongInfoValue_CutToFitAndKeyMatchesTheCut) {
  Encoder e(0);
  ASSERT_TRUE(e.info_string("ver_sw", std::string(70000, 'v')));
  const std::vector<Message> m = messages(bytes_of(e.bytes()));
  ASSERT_EQ(m.size(), 2u);
  const Bytes& p = m[1].payload;
  const std::string key(p.begin() + 1, p.begin() + 1 + p[0]);
  const std::size_t value_size = p.size() - 1 - p[0];
  EXPECT_EQ(key, "char[" + std::to_string(value_size) + "] ver_sw");
  EXPECT_GT(value_size, 60000u);
}

TEST(UlogEncoder, TruncateUtf8_KeepsWholeSequences) {
  EXPECT_EQ(truncate_utf8("abc", 5), "abc");
  EXPECT_EQ(truncate_utf8("ab\xE2\x82\xAC", 4), "ab");  // € is 3 bytes: not cut in half
  EXPECT_EQ(truncate_utf8("ab\xE2\x82\xAC", 5), "ab\xE2\x82\xAC");
  EXPECT_EQ(truncate_utf8("", 0), "");
}

// Odd cases written and read back: a topic with no data, a format of only a timestamp, empty strings.
TEST(UlogEncoder, OddCases_RoundTrip) {
  Encoder e(5);
  ASSERT_TRUE(e.info_string("empty", ""));
  ASSERT_TRUE(e.format(Format{.name = "only_time", .fields = {{.type = "uint64_t", .name = "timestamp"}}}));
  ASSERT_TRUE(e.format(one_double("never_published")));
  const auto a = e.add_logged("only_time");
  const auto b = e.add_logged("never_published");
  ASSERT_TRUE(a && b);
  const std::uint64_t t = 42;
  ASSERT_TRUE(e.data(*a, std::as_bytes(std::span(&t, 1))));
  e.log(LogLevel::Debug, 43, "");
  const std::vector<Message> m = messages(bytes_of(e.bytes()));
  std::string kinds;
  for (const Message& x : m) kinds += x.type;
  EXPECT_EQ(kinds, "BIFFAADL");
  EXPECT_EQ(m[1].payload, cat({{13}, str("char[0] empty")}));
  EXPECT_EQ(m[6].payload, (Bytes{0, 0, 42, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(m[7].payload, (Bytes{'7', 43, 0, 0, 0, 0, 0, 0, 0}));
}

TEST(UlogFileWriter, Close_WritesEveryByteTheEncoderMade) {
  const auto path = std::filesystem::path(::testing::TempDir()) / "writer_test.ulg";
  auto w = FileWriter::create(path, 9);
  ASSERT_TRUE(w);
  ASSERT_TRUE(w->encoder().format(one_double("a")));
  const auto id = w->encoder().add_logged("a");
  ASSERT_TRUE(id);
  std::array<std::byte, 16> payload{};
  for (int i = 0; i < 30000; ++i) {  // ≈ 630 kB: flushed on the way
    ASSERT_TRUE(w->encoder().data(*id, payload));
    w->flush_if_large();
  }
  const auto size = w->close();
  ASSERT_TRUE(size);
  EXPECT_EQ(*size, std::filesystem::file_size(path));
  std::ifstream in(path, std::ios::binary);
  const Bytes file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::vector<Message> m = messages(file);
  EXPECT_EQ(m.size(), 3u + 30000u);
}

TEST(UlogFileWriter, UnwritablePath_Io) {
  EXPECT_EQ(FileWriter::create("/nonexistent-dir/x.ulg", 0).error(), UlogError::Io);
}

}  // namespace
}  // namespace rejuv::ulog
