// The plant library in one include: quadrotor + mixer, sensor models and wind (docs/design.md §9).
#pragma once

#include "rejuv/plant/quadrotor.hpp"
#include "rejuv/plant/sensor_samples.hpp"
#include "rejuv/plant/sensors.hpp"
#include "rejuv/plant/wind.hpp"
