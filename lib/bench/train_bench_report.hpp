#pragma once
// `bench train`'s report of one config's measurements: a few lines of text, or one JSON object.
#include <string>

#include "bench/train_bench.hpp"
#include "train/train_config.hpp"

namespace f16race::bench {

// The median rate, the median run's time breakdown and its network floor, as lines of text.
std::string train_bench_text(const std::string& path, const train::TrainConfig& cfg, const TrainBenchResult& res);
// The same and every run's figures, the CPU and the BLAS kernels: one JSON object and a newline.
std::string train_bench_json(const std::string& path, const train::TrainConfig& cfg, const TrainBenchResult& res);

}  // namespace f16race::bench
