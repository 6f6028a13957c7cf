// Policy loader, model and compilation to cap::ModeTable (docs/design.md §3–§4).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>

#include "rejuv/policy/policy.hpp"

namespace rejuv::policy {
namespace {

const std::filesystem::path kRepo(REJUV_SOURCE_DIR);

constexpr std::string_view kHeader =
    R"pb(name: "t"
services { name: "ctl" }
services { name: "drv" level: DRIVER }
objects { name: "controls" kind: TOPIC type: "rejuv::msg::ActuatorControls" role: ACTUATOR }
objects { name: "limits" kind: LIMITS }
)pb";  // 5 lines: a test's own text starts on line 6

Result<Policy, LoadError> parse_with_header(std::string_view body) {
  return parse_policy(std::string(kHeader) + std::string(body), "mem.policy.pbtxt");
}

// Column of `token` on 1-based `line` of `text` (1-based), 0 if absent.
int column_of(std::string_view text, int line, std::string_view token) {
  std::size_t start = 0;
  for (int l = 1; l < line && start != std::string_view::npos; ++l) {
    start = text.find('\n', start);
    start = start == std::string_view::npos ? start : start + 1;
  }
  if (start == std::string_view::npos) {
    return 0;
  }
  const std::string_view row = text.substr(start, text.find('\n', start) - start);
  const std::size_t at = row.find(token);
  return at == std::string_view::npos ? 0 : static_cast<int>(at) + 1;
}

// The body must be refused as Semantic at `line`, at the column where `token` starts on that line (the
// field the error is about; "" = do not check the column), with `part` in the message.
void expect_semantic(std::string_view body, int line, std::string_view token, std::string_view part) {
  const std::string text = std::string(kHeader) + std::string(body);
  const auto r = parse_policy(text, "mem.policy.pbtxt");
  ASSERT_FALSE(r.has_value()) << "accepted:\n" << body;
  EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic) << r.error().to_string();
  EXPECT_EQ(r.error().where.line, line) << r.error().to_string();
  if (!token.empty()) {
    const int column = column_of(text, line, token);
    ASSERT_GT(column, 0) << "test bug: token not on the line";
    EXPECT_EQ(r.error().where.column, column) << r.error().to_string();
  }
  EXPECT_NE(r.error().message.find(part), std::string::npos) << r.error().to_string();
}

// ---- the model ----

TEST(PolicyModel, ValidPolicy_CellsHoldRightsAndOriginGrant) {
  const auto p = parse_with_header(
      "grants { service: \"ctl\" object: \"controls\" rights: \"W\" modes: [MC, SC] }\n"
      "grants { service: \"drv\" object: \"controls\" rights: \"R\" modes: [MC, RB, SC, UPDATE, CP] }\n");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const ServiceId ctl = *p->find_service("ctl");
  const ObjectId controls = *p->find_object("controls");
  EXPECT_EQ(p->rights(ctl, controls, SrMode::MC), Rights(Right::Write));
  EXPECT_EQ(p->rights(ctl, controls, SrMode::RB), Rights::none());
  EXPECT_EQ(p->cell(ctl, controls, SrMode::SC).grant, std::optional<std::size_t>(0));
  EXPECT_EQ(p->grants()[0].where.line, 6);
  EXPECT_EQ(p->grants()[0].where.column, 1);
}

TEST(PolicyModel, Ids_AreDeclarationOrder) {
  const auto p = parse_with_header("");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_EQ(p->find_service("drv"), ServiceId(1));
  EXPECT_EQ(p->find_object("limits"), ObjectId(1));
  EXPECT_EQ(p->find_object("nope"), std::nullopt);
}

TEST(PolicyModel, TopicQueueDepthUnset_DefaultsToFour) {
  const auto p = parse_with_header("");
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(p->object(ObjectId(0)).queue_depth, kDefaultQueueDepth);
  EXPECT_EQ(p->object(ObjectId(1)).queue_depth, 0U);  // not a topic
}

TEST(PolicyModel, NetworkRight_MakesServiceNetworkFacing) {
  const auto p = parse_policy(
      "services { name: \"a\" }\nservices { name: \"b\" }\nservices { name: \"c\" network_facing: true }\n"
      "objects { name: \"net\" kind: NETWORK }\n"
      "grants { service: \"a\" object: \"net\" rights: \"R\" modes: [MC] }\n",
      "mem");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_TRUE(p->is_network_facing(ServiceId(0)));
  EXPECT_FALSE(p->is_network_facing(ServiceId(1)));
  EXPECT_TRUE(p->is_network_facing(ServiceId(2)));
}

// ---- one test per semantic error ----

TEST(PolicyLoader, GrantUnknownService_SemanticWithSuggestion) {
  expect_semantic("grants { service: \"ctll\" object: \"controls\" rights: \"W\" modes: [MC] }\n", 6,
                  "service:", "did you mean \"ctl\"");
}

TEST(PolicyLoader, GrantUnknownObject_Semantic) {
  expect_semantic("grants { service: \"ctl\" object: \"ctrls\" rights: \"W\" modes: [MC] }\n", 6,
                  "object:", "unknown object \"ctrls\"");
}

TEST(PolicyLoader, GrantWithoutService_Semantic) {
  expect_semantic("grants { object: \"controls\" rights: \"W\" modes: [MC] }\n", 6, "grants",
                  "without a `service`");
}

TEST(PolicyLoader, DuplicateService_SemanticNamesFirstLine) {
  expect_semantic("services { name: \"ctl\" }\n", 6, "name:", "already declared at line 2");
}

TEST(PolicyLoader, DuplicateObject_Semantic) {
  expect_semantic("objects { name: \"limits\" kind: LIMITS }\n", 6, "name:", "duplicate object");
}

TEST(PolicyLoader, ServiceNameWithSpace_Semantic) {
  expect_semantic("services { name: \"a b\" }\n", 6, "name:", "letters");
}

TEST(PolicyLoader, ServiceNamedWildcard_Semantic) {
  expect_semantic("services { name: \"*\" }\n", 6, "name:", "service name");
}

TEST(PolicyLoader, TwoRejuvenationServices_Semantic) {
  const auto r = parse_policy(
      "services { name: \"a\" rejuvenation: true }\nservices { name: \"b\" rejuvenation: true }\n", "mem");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic);
  EXPECT_EQ(r.error().where.line, 2);
  EXPECT_NE(r.error().message.find("only one service"), std::string::npos) << r.error().to_string();
}

TEST(PolicyLoader, DuplicateGrantOverlappingModes_Semantic) {
  expect_semantic(
      "grants { service: \"ctl\" object: \"controls\" rights: \"W\" modes: [MC, SC] }\n"
      "grants { service: \"ctl\" object: \"controls\" rights: \"R\" modes: [SC, CP] }\n",
      7, "grants", "already granted in SC at line 6");
}

TEST(PolicyLoader, SameServiceObjectDisjointModes_Accepted) {
  const auto p = parse_with_header(
      "grants { service: \"ctl\" object: \"controls\" rights: \"W\" modes: [MC] }\n"
      "grants { service: \"ctl\" object: \"controls\" rights: \"R\" modes: [SC, CP] }\n");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_EQ(p->rights_any_mode(ServiceId(0), ObjectId(0)), Rights(Right::Read) | Right::Write);
}

TEST(PolicyLoader, EmptyRights_Semantic) {
  expect_semantic("grants { service: \"ctl\" object: \"controls\" rights: \"\" modes: [MC] }\n", 6,
                  "rights:", "rights are empty");
}

TEST(PolicyLoader, UnknownRightLetter_Semantic) {
  expect_semantic("grants { service: \"ctl\" object: \"controls\" rights: \"RX\" modes: [MC] }\n", 6,
                  "rights:", "unknown letter 'X'");
}

TEST(PolicyLoader, RepeatedRightLetter_Semantic) {
  expect_semantic("grants { service: \"ctl\" object: \"controls\" rights: \"RWR\" modes: [MC] }\n", 6,
                  "rights:", "letter 'R' is repeated");
}

TEST(PolicyLoader, GrantWithoutModes_SemanticAtGrant) {
  expect_semantic("grants { service: \"ctl\" object: \"controls\" rights: \"W\" }\n", 6, "grants",
                  "has no `modes`");
}

TEST(PolicyLoader, ModeUnspecified_SemanticAtMode) {
  expect_semantic(
      "grants { service: \"ctl\" object: \"controls\" rights: \"W\" modes: [MC, MODE_UNSPECIFIED] }\n", 6, "",
      "MODE_UNSPECIFIED is not a mode");
}

TEST(PolicyLoader, ModeListedTwice_Semantic) {
  expect_semantic("grants { service: \"ctl\" object: \"controls\" rights: \"W\" modes: [MC, MC] }\n", 6, "",
                  "listed twice");
}

TEST(PolicyLoader, TopicWithoutType_Semantic) {
  expect_semantic("objects { name: \"sp\" kind: TOPIC }\n", 6, "name:", "needs a `type`");
}

TEST(PolicyLoader, QueueDepthNotPowerOfTwo_Semantic) {
  expect_semantic("objects { name: \"sp\" kind: TOPIC type: \"T\" queue_depth: 12 }\n", 6, "queue_depth",
                  "power of two");
}

TEST(PolicyLoader, QueueDepthAbove1024_Semantic) {
  expect_semantic("objects { name: \"sp\" kind: TOPIC type: \"T\" queue_depth: 2048 }\n", 6, "queue_depth",
                  "1..1024");
}

TEST(PolicyLoader, QueueDepth1024_Accepted) {
  EXPECT_TRUE(
      parse_with_header("objects { name: \"sp\" kind: TOPIC type: \"T\" queue_depth: 1024 }\n").has_value());
}

TEST(PolicyLoader, PersistentSizeZero_Semantic) {
  expect_semantic("objects { name: \"cell\" kind: PERSISTENT }\n", 6, "name:", "1..4096");
}

TEST(PolicyLoader, PersistentSizeTooLarge_Semantic) {
  expect_semantic("objects { name: \"cell\" kind: PERSISTENT size_bytes: 4097 }\n", 6, "size_bytes",
                  "1..4096");
}

TEST(PolicyLoader, RoleOnNonTopic_Semantic) {
  expect_semantic("objects { name: \"cp\" kind: CHECKPOINT role: SETPOINT }\n", 6, "role:", "topics only");
}

TEST(PolicyLoader, TypeOnNonTopic_Semantic) {
  expect_semantic("objects { name: \"cp\" kind: CHECKPOINT type: \"T\" }\n", 6, "type:", "topics only");
}

TEST(PolicyLoader, SizeOnNonPersistent_Semantic) {
  expect_semantic("objects { name: \"cp\" kind: CHECKPOINT size_bytes: 4 }\n", 6, "size_bytes",
                  "PERSISTENT objects only");
}

TEST(PolicyLoader, ObjectWithoutKind_Semantic) {
  expect_semantic("objects { name: \"x\" }\n", 6, "name:", "needs a `kind`");
}

TEST(PolicyLoader, DenyUnknownService_Semantic) {
  expect_semantic("deny { id: \"d\" service: \"nobody\" object: \"*\" }\n", 6,
                  "service:", "unknown service \"nobody\"");
}

TEST(PolicyLoader, DenyUnknownExceptService_Semantic) {
  expect_semantic("deny { id: \"d\" service: \"*\" object: \"*\" except_services: \"nobody\" }\n", 6,
                  "except_services", "unknown service \"nobody\"");
}

TEST(PolicyLoader, DenyWithoutId_Semantic) {
  expect_semantic("deny { service: \"*\" object: \"*\" }\n", 6, "deny", "without an `id`");
}

TEST(PolicyLoader, DenyDuplicateId_Semantic) {
  expect_semantic(
      "deny { id: \"d\" service: \"*\" object: \"*\" }\ndeny { id: \"d\" service: \"*\" object: \"*\" }\n", 7,
      "id:", "duplicate deny id");
}

TEST(PolicyLoader, DenyEmptyServiceSuggestsWildcard_Semantic) {
  expect_semantic("deny { id: \"d\" object: \"*\" }\n", 6, "deny", "use \"*\" for any");
}

TEST(PolicyLoader, DenyKindContradictsObject_Semantic) {
  expect_semantic("deny { id: \"d\" service: \"*\" object: \"limits\" kind: NETWORK }\n", 6,
                  "kind:", "can never match");
}

TEST(PolicyLoader, DenyBadRights_Semantic) {
  expect_semantic("deny { id: \"d\" service: \"*\" object: \"*\" rights: \"Q\" }\n", 6,
                  "rights:", "unknown letter 'Q'");
}

// ---- declared topic types (`types`: the graph's own IDL, SDK rejuv_add_topics) ----

TEST(PolicyLoader, DeclaredType_FoundAndUsableAsATopicType) {
  const auto r = parse_with_header(
      "types { name: \"hello::Greeting\" size_bytes: 24 align_bytes: 8 }\n"
      "objects { name: \"greetings\" kind: TOPIC type: \"hello::Greeting\" }\n");
  ASSERT_TRUE(r.has_value()) << r.error().to_string();
  const DeclaredType* t = r->find_type("hello::Greeting");
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->size_bytes, 24U);
  EXPECT_EQ(t->align_bytes, 8U);
  EXPECT_EQ(t->where.line, 6);
  EXPECT_EQ(r->find_type("hello::Other"), nullptr);
  EXPECT_EQ(r->object(*r->find_object("greetings")).type, "hello::Greeting");
}

TEST(PolicyLoader, DeclaredTypeUnderRejuv_Semantic) {
  expect_semantic("types { name: \"rejuv::msg::Setpoint\" size_bytes: 8 align_bytes: 8 }\n", 6, "name:",
                  "names under rejuv:: are the project's own");
}

TEST(PolicyLoader, DeclaredTypeBadName_Semantic) {
  expect_semantic("types { name: \"hello:Greeting\" size_bytes: 8 align_bytes: 8 }\n", 6, "name:",
                  "IDL scoped name");
  expect_semantic("types { name: \"9lives\" size_bytes: 8 align_bytes: 8 }\n", 6, "name:", "IDL scoped name");
  expect_semantic("types { name: \"hello::\" size_bytes: 8 align_bytes: 8 }\n", 6, "name:", "IDL scoped name");
}

TEST(PolicyLoader, DeclaredTypeTwice_Semantic) {
  expect_semantic(
      "types { name: \"a::B\" size_bytes: 8 align_bytes: 8 }\ntypes { name: \"a::B\" size_bytes: 8 align_bytes: 8 }\n",
      7, "name:", "duplicate type \"a::B\": already declared at line 6");
}

TEST(PolicyLoader, DeclaredTypeSizeOrAlignment_Semantic) {
  expect_semantic("types { name: \"a::B\" align_bytes: 8 }\n", 6, "name:", "needs size_bytes in 1..4096");
  expect_semantic("types { name: \"a::B\" size_bytes: 5000 align_bytes: 8 }\n", 6, "size_bytes:", "got 5000");
  expect_semantic("types { name: \"a::B\" size_bytes: 12 align_bytes: 8 }\n", 6, "align_bytes:",
                  "divides its size 12, got 8");
  expect_semantic("types { name: \"a::B\" size_bytes: 12 align_bytes: 3 }\n", 6, "align_bytes:", "power of two");
  expect_semantic("types { name: \"a::B\" size_bytes: 12 }\n", 6, "name:", "got 0");
}

TEST(PolicyLoader, NoServices_Semantic) {
  const auto r = parse_policy("name: \"empty\"\n", "mem");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Semantic);
  EXPECT_EQ(r.error().where.line, 1);
  EXPECT_NE(r.error().message.find("no `services`"), std::string::npos);
}

TEST(PolicyLoader, UnknownField_Syntax) {
  const auto r = parse_with_header("grants { service: \"ctl\" bogus: 1 }\n");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::Syntax);
  EXPECT_EQ(r.error().where.line, 6);
  EXPECT_EQ(r.error().where.column, 25);
}

TEST(PolicyLoader, MissingFile_CannotRead) {
  const auto r = load_policy("/nonexistent/x.policy.pbtxt");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().kind, LoadErrorKind::CannotRead);
}

TEST(PolicyLoader, Garbage_NeverCrashes) {
  for (const std::string_view text :
       {"grants {", "services { name: 3 }", "objects { kind: 99 }", "grants { modes: 42 }",
        "deny { kind: 77 }", "objects { name: \"a\" kind: TOPIC type: \"T\" role: 9 }",
        "services { name: \"s\" level: 5 }"}) {
    const auto r = parse_policy(text, "garbage");
    EXPECT_FALSE(r.has_value()) << text;
  }
}

// Every prefix of the reference policy either loads or is refused with a position; never a crash.
TEST(PolicyLoader, TruncatedReferencePolicy_RefusedWithPositionNeverCrashes) {
  std::ifstream in(kRepo / "policies" / "quad_sr.policy.pbtxt");
  std::ostringstream buf;
  buf << in.rdbuf();
  const std::string text = buf.str();
  int refused = 0;
  for (std::size_t cut = 0; cut < text.size(); cut += 61) {
    const auto r = parse_policy(std::string_view(text).substr(0, cut), "cut");
    if (!r.has_value()) {
      ++refused;
      EXPECT_GT(r.error().where.line, 0) << "cut at " << cut << ": " << r.error().to_string();
    }
  }
  EXPECT_GT(refused, 0);
}

// ---- the malformed examples shipped in policies/examples ----

// Every malformed example is refused at the line its author marked "<- error", with the kind named in
// its "# expect-error:" header.
TEST(PolicyExamples, MalformedFiles_RefusedAtMarkedLine) {
  int seen = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kRepo / "policies" / "examples")) {
    const std::string name = entry.path().filename().string();
    if (!name.starts_with("malformed_")) {
      continue;
    }
    ++seen;
    std::ifstream in(entry.path());
    std::string line;
    int n = 0;
    int marked = 0;
    std::string kind;
    while (std::getline(in, line)) {
      ++n;
      if (line.find("<- error") != std::string::npos && !line.starts_with("#")) {
        marked = n;
      }
      if (line.starts_with("# expect-error: ")) {
        kind = line.substr(16);
      }
    }
    ASSERT_GT(marked, 0) << name << " has no \"<- error\" marker";
    ASSERT_TRUE(kind == "syntax" || kind == "semantic") << name << " has no expect-error header";
    const auto r = load_policy(entry.path());
    ASSERT_FALSE(r.has_value()) << name << " was accepted";
    EXPECT_EQ(r.error().kind, kind == "syntax" ? LoadErrorKind::Syntax : LoadErrorKind::Semantic)
        << r.error().to_string();
    EXPECT_EQ(r.error().where.line, marked) << r.error().to_string();
    EXPECT_GT(r.error().where.column, 0) << r.error().to_string();
    EXPECT_EQ(r.error().where.file, entry.path().string());
  }
  EXPECT_GE(seen, 4);
}

// ---- compilation to the kernel's ModeTable ----

TEST(PolicyCompile, QuadSr_SlotsCarryPerModeRightsOfTheGrants) {
  const auto p = load_policy(kRepo / "policies" / "quad_sr.policy.pbtxt");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const cap::ModeTable t = compile(*p);
  ASSERT_EQ(t.services.size(), p->services().size());
  ASSERT_EQ(t.objects.size(), p->objects().size());
  std::size_t granted_pairs = 0;
  for (const Service& s : p->services()) {
    for (const Object& o : p->objects()) {
      granted_pairs += p->rights_any_mode(s.id, o.id).empty() ? 0 : 1;
    }
  }
  EXPECT_EQ(t.slots.size(), granted_pairs);
  for (const cap::SlotGrant& slot : t.slots) {
    for (const SrMode m : kAllModes) {
      EXPECT_EQ(slot.rights[index_of(m)], p->rights(slot.service, slot.object, m))
          << t.services[slot.service.value()] << " / " << t.objects[slot.object.value()].name << " / "
          << to_string(m);
    }
  }
}

TEST(PolicyCompile, QuadSr_CheckpointOnlyOutsideMc) {
  const auto p = load_policy(kRepo / "policies" / "quad_sr.policy.pbtxt");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const cap::ModeTable t = compile(*p);
  const ServiceId cp = *p->find_service("checkpoint_p");
  const ObjectId ck = *p->find_object("checkpoint");
  bool found = false;
  for (const cap::SlotGrant& slot : t.slots) {
    if (slot.service == cp && slot.object == ck) {
      found = true;
      EXPECT_TRUE(slot.rights[index_of(SrMode::MC)].empty());
      EXPECT_EQ(slot.rights[index_of(SrMode::CP)], Rights(Right::Write));
    }
  }
  EXPECT_TRUE(found);
}

TEST(PolicyCompile, Slots_StartAtOnePerServiceInObjectOrder) {
  const auto p = parse_with_header(
      "grants { service: \"drv\" object: \"limits\" rights: \"R\" modes: [MC] }\n"
      "grants { service: \"drv\" object: \"controls\" rights: \"R\" modes: [SC] }\n"
      "grants { service: \"ctl\" object: \"controls\" rights: \"W\" modes: [MC] }\n");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const cap::ModeTable t = compile(*p);
  ASSERT_EQ(t.slots.size(), 3U);
  // ctl: controls → slot 1. drv: controls (object 0) → slot 1, limits (object 1) → slot 2.
  EXPECT_EQ(t.slots[0].service, ServiceId(0));
  EXPECT_EQ(t.slots[0].slot, Slot(1));
  EXPECT_EQ(t.slots[1].service, ServiceId(1));
  EXPECT_EQ(t.slots[1].object, ObjectId(0));
  EXPECT_EQ(t.slots[1].slot, Slot(1));
  EXPECT_EQ(t.slots[2].object, ObjectId(1));
  EXPECT_EQ(t.slots[2].slot, Slot(2));
  EXPECT_EQ(t.slots[2].rights[index_of(SrMode::MC)], Rights(Right::Read));
  EXPECT_TRUE(t.slots[2].rights[index_of(SrMode::SC)].empty());
  EXPECT_EQ(t.objects[1].kind, ObjectKind::Limits);
  EXPECT_EQ(t.objects[1].name, "limits");
}

TEST(PolicyCompile, SameInput_SameTable) {
  const auto a = load_policy(kRepo / "policies" / "quad_sr.policy.pbtxt");
  const auto b = load_policy(kRepo / "policies" / "quad_sr.policy.pbtxt");
  ASSERT_TRUE(a.has_value() && b.has_value());
  const cap::ModeTable ta = compile(*a);
  const cap::ModeTable tb = compile(*b);
  ASSERT_EQ(ta.slots.size(), tb.slots.size());
  for (std::size_t i = 0; i < ta.slots.size(); ++i) {
    EXPECT_EQ(ta.slots[i].slot, tb.slots[i].slot);
    EXPECT_EQ(ta.slots[i].object, tb.slots[i].object);
  }
}

}  // namespace
}  // namespace rejuv::policy
