#include "train/train_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace f16race::train {

std::string clock_text(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--:--";
  char b[32];
  std::snprintf(b, sizeof b, "%d:%02d", static_cast<int>(seconds) / 60, static_cast<int>(seconds) % 60);
  return b;
}

namespace {
// One value of the progress line, or "-" (right-aligned to the same width) when there is none
// yet: no race ended in the update, so no winrate or return to show.
std::string shown(double v, const char* format, int width) {
  char b[64];
  if (std::isfinite(v)) std::snprintf(b, sizeof b, format, v);
  else std::snprintf(b, sizeof b, "%*s", width, "-");
  return b;
}
}  // namespace

std::string progress_line(const MetricsRow& r, std::int64_t total_env_steps, const std::string& prefix) {
  // The last update may overshoot the budget (updates are whole): shown as 100 %, 0:00 to go.
  const double frac = std::min(1.0, static_cast<double>(r.env_steps) / static_cast<double>(total_env_steps));
  const double eta = frac > 0 ? r.wall_s * (1.0 - frac) / frac : NAN;
  // Fits 100 columns with a "member m: " prefix; goal distance, HL return and the high level's
  // diagnostics are in metrics.csv and curves.png.
  char line[256];
  std::snprintf(line, sizeof line, "%s%5.1f%% %s ETA %s | upd %lld %s | %s ft/s | win %s | finish %s | LL ret %s",
                prefix.c_str(), 100.0 * frac, clock_text(r.wall_s).c_str(), clock_text(eta).c_str(),
                static_cast<long long>(r.update), r.phase.c_str(), shown(r.airspeed_ftps, "%4.0f", 4).c_str(),
                shown(r.winrate, "%.2f", 4).c_str(), shown(r.finish_rate, "%.2f", 4).c_str(),
                shown(r.ll_return, "%5.1f", 5).c_str());
  return line;
}

MetricTrend metric_trend(const std::vector<MetricsRow>& rows, double MetricsRow::*field) {
  std::vector<double> v;
  for (const auto& r : rows)
    if (std::isfinite(r.*field)) v.push_back(r.*field);
  MetricTrend t;
  if (v.empty()) return t;
  const std::size_t n = v.size(), k = std::max<std::size_t>(1, n / 10);
  auto mean = [&](std::size_t a, std::size_t b) {
    double s = 0;
    for (std::size_t i = a; i < b; ++i) s += v[i];
    return s / static_cast<double>(b - a);
  };
  t.first = mean(0, k);
  t.last = mean(n - k, n);
  return t;
}

std::string metric_trends_text(const std::vector<MetricsRow>& rows) {
  std::string line;
  auto add = [&](const char* name, double MetricsRow::*field, const char* format) {
    const MetricTrend t = metric_trend(rows, field);
    if (std::isnan(t.first)) return;
    char buf[96];
    std::snprintf(buf, sizeof buf, format, t.first, t.last);
    line += (line.empty() ? "" : ", ") + std::string(name) + " " + buf;
  };
  add("goal distance", &MetricsRow::goal_dist_ft, "%.0f -> %.0f ft");
  add("finish rate", &MetricsRow::finish_rate, "%.2f -> %.2f");
  add("LL return", &MetricsRow::ll_return, "%.2f -> %.2f");
  add("HL return", &MetricsRow::hl_return, "%.2f -> %.2f");
  add("airspeed", &MetricsRow::airspeed_ftps, "%.0f -> %.0f ft/s");
  return line;
}

namespace {
// printf into a std::string, as long as it comes (a run folder's name has no bound).
template <class... A>
std::string text(const char* format, A... a) {
  std::string s(static_cast<std::size_t>(std::snprintf(nullptr, 0, format, a...)), '\0');
  std::snprintf(s.data(), s.size() + 1, format, a...);
  return s;
}
}  // namespace

std::string summary_text(const TrainSummary& sum, const TrainConfig& cfg, const std::string& run_dir,
                         int world_size) {
  std::string out = text("done: %lld updates, %lld env steps, %lld HL gradient steps\n",
                         static_cast<long long>(sum.updates), static_cast<long long>(sum.env_steps),
                         static_cast<long long>(sum.hl_grad_steps));
  if (sum.env_steps < cfg.loop.total_env_steps)
    out += text("stopped by --max-updates at %lld of %lld env steps (checkpoint written); continue with --resume %s\n",
                static_cast<long long>(sum.env_steps), static_cast<long long>(cfg.loop.total_env_steps),
                run_dir.c_str());
  else if (cfg.loop.hl_tail_members > 1)
    out += text("high-level policy: greedy on the mean of %d tails' critics (the run's and %s/members/1..%d; "
                "train.hl_tail_members)\n",
                cfg.loop.hl_tail_members, run_dir.c_str(), cfg.loop.hl_tail_members - 1);
  if (world_size > 1)
    out += text("group of %d ranks: rank 0 spent %.0f%% of its time in collectives\n", world_size,
                100.0 * sum.communication_s / std::max(sum.time.total, 1e-9));
  if (!sum.curves_problem.empty()) out += "no curves.png: " + sum.curves_problem + "\n";
  if (sum.rows.empty()) return out;  // a resumed run that had already reached its budget: no trend to show
  // Only what was measured: a run in which no race ended has no finish rate to compare.
  const std::string trends = metric_trends_text(sum.rows);
  if (trends.empty()) return out + "no race ended in this run yet: nothing to compare between its first and last tenth\n";
  return out + "first -> last tenth: " + trends + "\n";
}

}  // namespace f16race::train
