#pragma once
// The learning-curve figure of a training run, from RUN/metrics.csv alone (no LibTorch), so it can
// be redrawn at any time, also while the run is still writing rows.
//
// Writes into the run folder:
//   curves_data.csv  env_steps_M, then per plotted metric NAME the raw value (NaN where the row
//                    gives none) and NAME_smooth, the running mean of the last
//                    kLearningCurveWindow valid values of NAME up to and including that row (NaN on
//                    rows where NAME itself is not valid, so the line runs across them)
//   curves.gp        the gnuplot script (kept so the figure can be restyled: `gnuplot curves.gp`)
//   curves.png       1600x1000, six panels against env steps: finish rate and winrate; LL return;
//                    HL return; HL diagnostics (q_spread left axis, greedy_entropy,
//                    off_center_share and middle_share_x/y/z right axis 0..1); ES end-atom and
//                    Huber shares (HL-phase rows
//                    only, or every row when there is no phase_hl column; y from 0 up to the
//                    data); goal distance. Raw points faint, running mean as a line; the metrics
//                    of a panel with no data are named in an empty frame.
//
// A metric column that is missing, or has no finite value, is left out of the figure; empty,
// nan and inf cells are skipped points. Rows without a finite env_steps are skipped. A last line
// without its newline and with too few cells is a row still being appended and is ignored.
#include <atomic>
#include <string>
#include <thread>

namespace f16race::io {

// Rows in the running mean of each metric (fewer at the start of a run).
inline constexpr int kLearningCurveWindow = 20;

// Reads RUN/metrics.csv and writes RUN/curves_data.csv, RUN/curves.gp and RUN/curves.png (the
// PNG atomically: a crash never leaves half an image). Returns true with `message` = the PNG path
// when the figure was made; false with `message` saying why when gnuplot is missing or failed
// (data and script are written anyway). Throws std::runtime_error (io::CsvError) naming the file
// when metrics.csv cannot be read or is malformed (no env_steps column, rows with the wrong
// number of cells, non-numeric text).
bool write_learning_curves(const std::string& run_dir, std::string* message);

// write_learning_curves on a thread of its own, so that training never waits for gnuplot (~0.1-0.3
// s a draw, ~3 % of a short 2-core run). The draw and its gnuplot run at nice 10: they take a core
// from training only while the draw lasts, at a tenth of its share. One draw at a time.
class BackgroundCurves {
 public:
  BackgroundCurves() = default;
  BackgroundCurves(const BackgroundCurves&) = delete;
  BackgroundCurves& operator=(const BackgroundCurves&) = delete;
  ~BackgroundCurves();  // waits for a draw under way
  // A draw is under way.
  bool busy() const { return busy_.load(); }
  // Starts a draw of `run_dir`'s curves (after waiting for the previous one).
  void start(const std::string& run_dir);
  // Waits for the draw under way, if any: "" when the draws since the last wait() made their
  // figures (or there were none), else why the last failing one did not (write_learning_curves'
  // message or exception).
  std::string wait();

 private:
  std::thread worker_;
  std::atomic<bool> busy_{false};
  std::string problem_;  // written by the worker, read after join
};

}  // namespace f16race::io
