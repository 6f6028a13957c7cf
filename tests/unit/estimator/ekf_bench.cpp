// Cost of the estimator and plant steps that the model-level SR simulation runs (docs/design.md §9, §11): it must run
// ≥ 1000× real time with the plant at 1 kHz and predict at 250 Hz, i.e. one simulated second in < 1 ms.
#include <benchmark/benchmark.h>

#include "rejuv/flight/ekf.hpp"
#include "rejuv/plant/quadrotor.hpp"
#include "rejuv/plant/sensors.hpp"

namespace {

using namespace std::chrono_literals;
using rejuv::Nanos;
using rejuv::Seconds;
using rejuv::flight::Ekf;
using rejuv::flight::EkfParams;
using rejuv::flight::EkfState;
using rejuv::plant::QuadParams;
using rejuv::plant::Quadrotor;

EkfState hover_state() {
  EkfState s;
  s.p_N_m = Eigen::Vector3d(0, 0, -3);
  return s;
}

void BM_EkfPredict(benchmark::State& state) {
  Ekf ekf(EkfParams::defaults(), hover_state());
  const Eigen::Vector3d w(0.01, -0.02, 0.03);
  const Eigen::Vector3d f(0.1, -0.05, -9.8);
  for (auto _ : state) {
    ekf.predict(w, f, Seconds{0.004});
    benchmark::DoNotOptimize(ekf);
  }
}
BENCHMARK(BM_EkfPredict);

void BM_EkfFuseGps(benchmark::State& state) {
  Ekf ekf(EkfParams::defaults(), hover_state());
  const rejuv::plant::GpsSample gps{.t = Nanos{0},
                                    .p_N_m = Eigen::Vector3d(0.01, 0, -3.02),
                                    .v_N_m_s = Eigen::Vector3d(0.01, 0.0, 0.0),
                                    .eph_m = 0.05,
                                    .epv_m = 0.1};
  for (auto _ : state) {
    // A copy per iteration keeps the covariance from collapsing over millions of updates; its cost (~2 kB) is
    // measured separately by BM_EkfCopy.
    Ekf e = ekf;
    benchmark::DoNotOptimize(e.fuse_gps(gps));
    benchmark::DoNotOptimize(e);
  }
}
BENCHMARK(BM_EkfFuseGps);

void BM_EkfFuseBaro(benchmark::State& state) {
  Ekf ekf(EkfParams::defaults(), hover_state());
  const rejuv::plant::BaroSample baro{.t = Nanos{0}, .altitude_m = 3.02, .pressure_pa = 0};
  for (auto _ : state) {
    Ekf e = ekf;
    benchmark::DoNotOptimize(e.fuse_baro(baro));
    benchmark::DoNotOptimize(e);
  }
}
BENCHMARK(BM_EkfFuseBaro);

void BM_EkfCopy(benchmark::State& state) {
  Ekf ekf(EkfParams::defaults(), hover_state());
  for (auto _ : state) {
    Ekf e = ekf;
    benchmark::DoNotOptimize(e);
  }
}
BENCHMARK(BM_EkfCopy);

void BM_QuadrotorStepRk4(benchmark::State& state) {
  const QuadParams p = QuadParams::jmavsim_default();
  Quadrotor quad(p, Quadrotor::hover_at(p, Eigen::Vector3d(0, 0, -3)));
  const Eigen::Vector4d command = Eigen::Vector4d::Constant(p.hover_level());
  for (auto _ : state) {
    quad.step(Seconds{1e-3}, command);
    benchmark::DoNotOptimize(quad);
  }
}
BENCHMARK(BM_QuadrotorStepRk4);

void BM_SensorSuiteStep(benchmark::State& state) {
  const QuadParams p = QuadParams::jmavsim_default();
  const auto truth = Quadrotor::hover_at(p, Eigen::Vector3d(0, 0, -3));
  rejuv::plant::SensorSuite sensors(rejuv::plant::SensorParams::defaults(), 1);
  Nanos t{0};
  for (auto _ : state) {
    benchmark::DoNotOptimize(sensors.step(t, truth, Eigen::Vector3d::Zero()));
    t += 1ms;
  }
}
BENCHMARK(BM_SensorSuiteStep);

// One simulated second of plant (1 kHz) + sensors + EKF (predict 250 Hz, GPS 10 Hz, baro and mag 50 Hz): the
// real-time factor is 1 s divided by this time.
void BM_SimulatedSecond(benchmark::State& state) {
  const QuadParams p = QuadParams::jmavsim_default();
  Quadrotor quad(p, Quadrotor::hover_at(p, Eigen::Vector3d(0, 0, -3)));
  rejuv::plant::SensorSuite sensors(rejuv::plant::SensorParams::defaults(), 1);
  Ekf ekf(EkfParams::defaults(), hover_state());
  const Eigen::Vector4d command = Eigen::Vector4d::Constant(p.hover_level());
  Nanos t{0};
  for (auto _ : state) {
    for (int i = 0; i < 1000; ++i) {
      quad.step(Seconds{1e-3}, command);
      t += 1ms;
      const auto s = sensors.step(t, quad.state(), quad.acceleration_N());
      if (s.gyro && s.accel) ekf.predict(s.gyro->omega_B_rad_s, s.accel->f_B_m_s2, Seconds{0.004});
      if (s.gps) benchmark::DoNotOptimize(ekf.fuse_gps(*s.gps));
      if (s.baro) benchmark::DoNotOptimize(ekf.fuse_baro(*s.baro));
      if (s.mag) benchmark::DoNotOptimize(ekf.fuse_mag(*s.mag));
    }
    benchmark::DoNotOptimize(ekf);
  }
  state.counters["realtime_factor"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SimulatedSecond)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
