// What signing adds per datagram at the network gate (docs/mavlink.md "Signing"): SignatureChecker::check on a
// signed MISSION_ITEM_INT (the largest frame of an upload) against split_frame alone — the envelope check of a
// gate without a key — and against decode(), what ext_link spends on the same frame. Timings live here, never
// in tests.
#include <benchmark/benchmark.h>

#include <vector>

#include "rejuv/mavlink/frame.hpp"
#include "rejuv/mavlink/messages.hpp"

namespace rejuv::mavlink {
namespace {

SigningKey bench_key() {
  return *SigningKey::from_hex("6c1a4e2f9b0d7c3e5a8f1b2d4c6e8a0b3d5f7a9c1e2b4d6f8a0c2e4b6d8f0a1c");
}

Frame signed_item(SigningTime timestamp) {
  MissionItemInt item{};
  item.seq = 3;
  item.frame = 1;  // MAV_FRAME_LOCAL_NED
  item.x = 12345;
  item.y = -678;
  item.z = -3.0F;
  return encode(item, Envelope{.seq = 1, .sysid = 255, .compid = 190},
                Signer{.key = bench_key(), .link_id = 1, .timestamp = timestamp});
}

void BM_SplitFrame_NoKey(benchmark::State& state) {
  const Frame f = signed_item(SigningClock::now());
  for (auto _ : state) benchmark::DoNotOptimize(split_frame(f.view()));
}
BENCHMARK(BM_SplitFrame_NoKey);

void BM_SignatureCheck(benchmark::State& state) {
  // A fresh timestamp per frame (the checker refuses a replay): frames made ahead, outside the timing.
  // The local clock is read once: the check compares with it, and reading it is not what is measured.
  const SigningTime start = SigningClock::now();
  std::vector<Frame> frames;
  for (std::uint64_t t = 1; t <= 4096; ++t) frames.push_back(signed_item(start + SigningClock::duration{t}));
  std::size_t i = 0;
  SignatureChecker checker(bench_key());
  for (auto _ : state) {
    if (i == frames.size()) {
      state.PauseTiming();
      checker = SignatureChecker(bench_key());
      i = 0;
      state.ResumeTiming();
    }
    auto ok = checker.check(frames[i++].view(), start);
    if (!ok) state.SkipWithError("a signed frame was refused");
    benchmark::DoNotOptimize(ok);
  }
}
BENCHMARK(BM_SignatureCheck);

void BM_Decode(benchmark::State& state) {
  const Frame f = signed_item(SigningClock::now());
  for (auto _ : state) benchmark::DoNotOptimize(decode(f.view()));
}
BENCHMARK(BM_Decode);

// The gate's work per vehicle frame when signing is on (kernel netgate.cpp): sign_frame checks the frame's
// envelope, id, length and checksum (check_frame) and signs it, without reading its payload.
void BM_SignFrame(benchmark::State& state) {
  const Frame unsigned_frame = encode(MissionItemInt{}, Envelope{.seq = 1, .sysid = 1, .compid = 1});
  const Signer signer{.key = bench_key(), .link_id = 0, .timestamp = SigningClock::now()};
  for (auto _ : state) benchmark::DoNotOptimize(sign_frame(unsigned_frame.view(), signer));
}
BENCHMARK(BM_SignFrame);

// Its baseline: the whole decode the gate ran on each frame before signing it (into a Message and a Packet),
// then the signing — BM_SignFrame / this is what reading only the envelope saves.
void BM_DecodeThenSignFrame(benchmark::State& state) {
  const Frame unsigned_frame = encode(MissionItemInt{}, Envelope{.seq = 1, .sysid = 1, .compid = 1});
  const Signer signer{.key = bench_key(), .link_id = 0, .timestamp = SigningClock::now()};
  for (auto _ : state) {
    benchmark::DoNotOptimize(decode(unsigned_frame.view()));
    benchmark::DoNotOptimize(sign_frame(unsigned_frame.view(), signer));
  }
}
BENCHMARK(BM_DecodeThenSignFrame);

}  // namespace
}  // namespace rejuv::mavlink

BENCHMARK_MAIN();
