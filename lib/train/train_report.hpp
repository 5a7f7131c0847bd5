#pragma once
// The lines `f16race train` prints about a run: a progress line per metrics row, and the closing
// summary (totals, how to continue, what improved between the first and last tenth of its rows).
// Torch-free.
#include <cmath>
#include <string>
#include <vector>

#include "train/metrics_file.hpp"
#include "train/trainer.hpp"

namespace f16race::train {

// "m:ss", or "--:--" for a time not known (negative or not finite).
std::string clock_text(double seconds);

// The progress line of `row` (no newline): share of the budget done, wall time and ETA, the
// update, throughput and the row's main metrics; `prefix` goes first ("member m: ").
std::string progress_line(const MetricsRow& row, std::int64_t total_env_steps, const std::string& prefix = "");

// A metric's mean over the first and the last tenth of the rows that have it (an update in which
// no race ended has no finish rate).
struct MetricTrend {
  double first = NAN, last = NAN;  // nan: no row has the metric
};
MetricTrend metric_trend(const std::vector<MetricsRow>& rows, double MetricsRow::*field);

// "goal distance 812 -> 640 ft, finish rate 0.10 -> 0.35, ...": the trends of goal distance,
// finish rate, LL and HL return and airspeed, only those measured; "" when none is.
std::string metric_trends_text(const std::vector<MetricsRow>& rows);

// The run's closing lines (each with its newline) after Trainer::run returned `sum` for the run of
// `config` in `run_dir`, trained by `world_size` ranks.
std::string summary_text(const TrainSummary& sum, const TrainConfig& config, const std::string& run_dir,
                         int world_size);

}  // namespace f16race::train
