#pragma once
// The study's scheduler (`f16race study`): trains every cell of a study that is not finished (a
// partial run resumes from its checkpoint), `jobs` at a time as child `f16race train` processes,
// one HL interval at a time: its runs, then its tournament as a child `f16race tournament`, then
// OUT/report/ with every interval raced so far. A stop request (the command's SIGINT or SIGTERM)
// is forwarded to the children once: a training checkpoints and stops, a tournament stops; the
// runner waits for them. Children die with the study (io::spawn_child), so even a kill -9 leaves
// no training holding a run folder.
#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "eval/study.hpp"

namespace f16race::eval {

// "dt8/es_d3_s3": a cell as the study's messages name it.
std::string cell_label(const StudyCell& cell);
// "to train", "to resume", "finished".
const char* cell_state_name(CellState state);
// A duration as "1h05m" (from an hour) or "3m07s"; "?" when negative, NaN or beyond 1e7 s.
std::string hms(double s);

// A running training as the progress line sees it, in env steps of the cell's whole training
// (its run and its tail members, CellStatus::work_total).
struct CellProgress {
  std::string label;
  std::int64_t work_done = 0;      // at the latest metrics rows
  std::int64_t work_at_start = 0;  // when this study started it
  std::int64_t work_total = 0;
  double elapsed_s = 0.0;          // since this study started it
};
// "study: 3/12 cells done | dt8/es_s1 40% ETA 1h02m | ... | study ETA 5h10m (trainings)\n": per
// cell its progress and ETA from its own rate since it started here; the study's ETA: the env
// steps left over every unfinished cell (`queued_steps_left` for those not started) at the
// running cells' summed rate.
std::string study_progress_line(std::size_t finished, std::size_t n_cells, const std::vector<CellProgress>& running,
                                double queued_steps_left);

struct StudyRun {
  StudyConfig config;
  std::vector<StudyCell> cells;  // plan_study's
  std::string config_path;       // copied to OUT/study.yaml and named in the report
  std::string out;               // the study folder
  std::string executable = "/proc/self/exe";  // the children's f16race: this very binary, even if rebuilt meanwhile
  const std::atomic<bool>* stop = nullptr;    // set (by a signal handler) to stop; never null
  std::function<void(const std::string&)> say;  // each progress message, whole lines
};

// Runs the study to its end (true) or until `stop` (false, every child stopped and waited for,
// the message saying how to continue already said). Throws io::InputError when gnuplot is
// missing, a run folder stays held by another training, a child fails or a tournament is
// incomplete, each naming the fix.
bool run_study(const StudyRun& run);

}  // namespace f16race::eval
