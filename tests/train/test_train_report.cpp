// The lines `f16race train` prints (lib/train/train_report.hpp) and when a run goes on to train
// its tail members (lib/train/tail_ensemble.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "train/tail_ensemble.hpp"
#include "train/train_report.hpp"

namespace f16race::train {
namespace {

std::vector<MetricsRow> rows_with_finish_rates(const std::vector<double>& rates) {
  std::vector<MetricsRow> rows(rates.size());
  for (std::size_t i = 0; i < rates.size(); ++i) {
    rows[i].finish_rate = rates[i];
    rows[i].goal_dist_ft = rows[i].ll_return = rows[i].hl_return = rows[i].airspeed_ftps = std::nan("");
  }
  return rows;
}

TEST(TrainerReport, TrendsAreTheFirstAndLastTenthOfTheRowsThatHaveTheMetric) {
  // 20 measured rows (and a row without a race): tenths of 2 rows each.
  std::vector<double> rates{std::nan("")};
  for (int i = 0; i < 20; ++i) rates.push_back(0.05 * i);
  const MetricTrend t = metric_trend(rows_with_finish_rates(rates), &MetricsRow::finish_rate);
  EXPECT_DOUBLE_EQ(t.first, 0.025);
  EXPECT_DOUBLE_EQ(t.last, 0.925);
  EXPECT_EQ(metric_trends_text(rows_with_finish_rates(rates)), "finish rate 0.03 -> 0.93");
  EXPECT_EQ(metric_trends_text(rows_with_finish_rates({std::nan("")})), "");
}

TEST(TrainerReport, SummaryNamesHowToContinueAndTheEnsemble) {
  TrainConfig cfg;
  cfg.loop.total_env_steps = 640;
  cfg.loop.hl_tail_members = 3;
  TrainSummary sum;
  sum.updates = 7;
  sum.env_steps = 320;
  EXPECT_EQ(summary_text(sum, cfg, "runs/x", 1),
            "done: 7 updates, 320 env steps, 0 HL gradient steps\n"
            "stopped by --max-updates at 320 of 640 env steps (checkpoint written); continue with --resume runs/x\n");
  EXPECT_FALSE(tail_members_due(cfg, sum));
  sum.env_steps = 640;
  sum.rows = rows_with_finish_rates({std::nan("")});
  EXPECT_EQ(summary_text(sum, cfg, "runs/x", 1),
            "done: 7 updates, 640 env steps, 0 HL gradient steps\n"
            "high-level policy: greedy on the mean of 3 tails' critics (the run's and runs/x/members/1..2; "
            "train.hl_tail_members)\n"
            "no race ended in this run yet: nothing to compare between its first and last tenth\n");
  EXPECT_TRUE(tail_members_due(cfg, sum));
  cfg.loop.hl_tail_members = 1;
  EXPECT_FALSE(tail_members_due(cfg, sum));
}

// A low-level update's row at `env_steps` and `wall_s`, the rest left at its defaults.
MetricsRow ll_row(std::int64_t update, std::int64_t env_steps, double wall_s) {
  MetricsRow r;
  r.update = update;
  r.phase = "ll";
  r.env_steps = env_steps;
  r.wall_s = wall_s;
  return r;
}

TEST(TrainerReport, ProgressLineStartsWithItsPrefixAndShare) {
  const MetricsRow r = ll_row(4, 160, 75.0);
  const std::string line = progress_line(r, 640, "member 2: ");
  EXPECT_EQ(line.rfind("member 2:  25.0% 1:15 ETA 3:45 | upd 4 ll |", 0), 0u) << line;
  EXPECT_EQ(clock_text(std::nan("")), "--:--");
}

// A person reads no "nan": an update in which no race ended shows "-" for what it has not seen.
// And the line fits 100 columns with the tail members' prefix and long-run values.
TEST(TrainerReport, ProgressLineShowsNoNanAndFitsOneHundredColumns) {
  MetricsRow r = ll_row(1, 32, 0.5);
  r.airspeed_ftps = 559.4;
  r.winrate = r.finish_rate = r.ll_return = r.hl_return = r.goal_dist_ft = r.q_spread = std::nan("");
  std::string line = progress_line(r, 640);
  EXPECT_EQ(line.find("nan"), std::string::npos) << line;
  EXPECT_NE(line.find("|  559 ft/s | win    - | finish    - | LL ret     -"), std::string::npos) << line;
  r.update = 99999;
  r.phase = "hl";
  r.env_steps = 640;
  r.wall_s = 99 * 60 + 59;
  r.airspeed_ftps = 1234.0;
  r.winrate = 0.5;
  r.finish_rate = 1.0;
  r.ll_return = -99.94;
  line = progress_line(r, 640, "member 2: ");
  EXPECT_LE(line.size(), 100u) << line;
  EXPECT_NE(line.find("| 1234 ft/s | win 0.50 | finish 1.00 | LL ret -99.9"), std::string::npos) << line;
  r.env_steps = 700;  // the last update overshoots the budget
  EXPECT_EQ(progress_line(r, 640).rfind("100.0% 99:59 ETA 0:00 |", 0), 0u) << progress_line(r, 640);
}

}  // namespace
}  // namespace f16race::train
