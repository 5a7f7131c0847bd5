#pragma once
// train.hl_tail_members K > 1: the run's high level is an ensemble of K HL-only tails of one low
// level (docs/learning.md, "An ensemble of tails"). The run forks RUN/members/1..K-1 at its tail's
// first update (Trainer::run) and they train after the run's own budget, each from its own
// streams; train_tail_members (trainer.hpp) trains them one after the other.
#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "train/trainer.hpp"

namespace f16race::train {

// Whether a run whose Trainer::run returned `run` goes on to train its tail members: it has some
// and reached its budget (one stopped by --max-updates trains them when resumed to its end).
bool tail_members_due(const TrainConfig& config, const TrainSummary& run);

struct TailEnsembleRun {
  std::vector<TrainSummary> members;  // of the members trained, in order
  bool interrupted = false;           // the last one was stopped (its checkpoint is written)
};

// The run's tail members after its own training, when tail_members_due: `trainer` (that run's,
// in `run_dir`) is released first, so its folder lock goes before the members take theirs. An
// empty result when they are not due. on_row(m, row) for every metrics row of member m.
TailEnsembleRun train_tail_ensemble(std::unique_ptr<Trainer> trainer, const std::string& run_dir,
                                    const TrainSummary& run, const std::atomic<bool>* stop = nullptr,
                                    const std::function<void(int, const MetricsRow&)>& on_row = {});

}  // namespace f16race::train
