#pragma once
// RUN/metrics.csv: one row per update, appended as the run goes, read back at a resume. The
// columns, the row as text, and the rows a resume keeps. Torch-free.
#include <array>
#include <cmath>
#include <cstdint>
#include <string>

#include "race/race_env.hpp"

namespace f16race::train {

// One metrics row; also what the progress display shows.
struct MetricsRow {
  std::int64_t update = 0;        // PPO + ES updates so far
  std::string phase;              // "ll" or "hl"
  std::int64_t env_steps = 0;     // LL steps summed over envs
  double wall_s = 0.0;
  double samples_per_s = 0.0;     // aircraft LL steps per second since the previous row
  double ll_return = 0.0;         // mean LL return of learner aircraft over races that ended
  double hl_return = 0.0;         // mean summed HL reward per learner aircraft and race
  double goal_dist_ft = 0.0;      // mean distance left to the HL goal when its interval ended
  double airspeed_ftps = 0.0;     // mean airspeed of learner aircraft in the race, per LL step (speed decides races)
  double winrate = 0.0;           // learner team wins / races ended (draws count half)
  double finish_rate = 0.0;       // races ended at the finish line / races ended
  double races = 0.0;             // races ended since the previous row
  double term[race::kNumCauses] = {};  // per cause, learner aircraft per race
  double policy_loss = 0.0, value_loss = 0.0, entropy = 0.0, approx_kl = 0.0, lr = 0.0;
  double es_loss = 0.0, q_mean = 0.0, epsilon = 0.0;
  // High level: gradient steps so far and the last ES update's diagnostics (agents::EsStats).
  std::int64_t hl_grad_steps = 0;
  double es_loss_heldout = std::nan("");  // the ES loss on its batch before the update's steps
  double es_end_atom_share = std::nan(""), es_huber_share = std::nan("");
  double q_spread = std::nan(""), greedy_entropy = std::nan(""), off_center_share = std::nan("");
  // Per goal axis x, y, z (track frame: along, right, up): greedy decisions on the middle bin.
  std::array<double, 3> middle_share{std::nan(""), std::nan(""), std::nan("")};
};

// metrics.csv's header (no newline), and a row as its line (with the newline); an average with no
// event behind it (no race ended, no ES update yet) is an empty cell, never "nan".
std::string metrics_header_line();
std::string metrics_csv_line(const MetricsRow& row);

// metrics.csv as a resume at `updates` keeps it: today's header (an older build's shorter header,
// a prefix of it, is extended and its rows padded), the rows up to `updates`, LF line ends. Reads
// a UTF-8 byte-order mark and CRLF or CR line ends; an empty file is the header alone. A row
// whose first cell is not an update count, or a header that is not metrics.csv's, throws
// io::InputError naming `path` and the line.
std::string metrics_kept_up_to(const std::string& text, std::int64_t updates, const std::string& path);

}  // namespace f16race::train
