// What `rejuv run --ulog` adds per routed message: the timestamp and payload appended as one 'D' message of
// the topic's format, flushed to a file in 256 kB writes (tools/ulog). Baseline: copying the same bytes into a
// buffer (what any recorder pays). Payloads of the square's busiest topics: SensorGyro (40 B),
// VehicleStateEstimate (200 B).
#include <benchmark/benchmark.h>

#include <cstring>
#include <filesystem>
#include <vector>

#include "rejuv/msgs/topic_types.hpp"
#include "rejuv/ulog/topics.hpp"
#include "rejuv/ulog/writer.hpp"

namespace {

using namespace rejuv;

template <class T>
void BM_UlogData(benchmark::State& state) {
  const ulog::TopicLayout* layout = ulog::find_layout(msgs::TopicTraits<T>::name);
  const auto path = std::filesystem::temp_directory_path() / "rejuv_ulog_bench.ulg";
  auto w = ulog::FileWriter::create(path, 0);
  if (!w || layout == nullptr) {
    state.SkipWithError("cannot open the file");
    return;
  }
  (void)w->encoder().format(ulog::topic_format("t", *layout));
  const ulog::MsgId id = *w->encoder().add_logged("t");
  std::vector<std::byte> msg(8 + sizeof(T));
  T payload{};
  std::uint64_t t = 0;
  for (auto _ : state) {
    t += 4000;
    std::memcpy(msg.data(), &t, 8);
    std::memcpy(msg.data() + 8, &payload, sizeof payload);
    benchmark::DoNotOptimize(w->encoder().data(id, msg));
    w->flush_if_large();
  }
  (void)w->close();
  std::filesystem::remove(path);
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(msg.size()));
}

template <class T>
void BM_CopyOnly(benchmark::State& state) {
  std::vector<std::byte> buf;
  buf.reserve(1 << 20);
  T payload{};
  for (auto _ : state) {
    if (buf.size() + sizeof payload > buf.capacity()) buf.clear();
    const auto* p = reinterpret_cast<const std::byte*>(&payload);
    buf.insert(buf.end(), p, p + sizeof payload);
    benchmark::DoNotOptimize(buf.data());
  }
}

BENCHMARK(BM_UlogData<rejuv_msg_SensorGyro>);
BENCHMARK(BM_CopyOnly<rejuv_msg_SensorGyro>);
BENCHMARK(BM_UlogData<rejuv_msg_VehicleStateEstimate>);
BENCHMARK(BM_CopyOnly<rejuv_msg_VehicleStateEstimate>);

}  // namespace

BENCHMARK_MAIN();
