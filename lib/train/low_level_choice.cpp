// train.ll_choice_snapshots: at the low level's freeze, the low level that flies the HL-only tail
// is chosen among the current one and the last pool snapshots' by their winrates against the
// autopilot (the rater, supplied by the caller). The final iterate is a draw: a run's snapshots
// differ by ~0.07 on held-out tracks, and that spread is the policy (docs/notebook/104).
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "io/atomic_file.hpp"
#include "train/trainer_state.hpp"

namespace f16race::train {

namespace fs = std::filesystem;

void Trainer::set_low_level_rater(LowLevelRater rate) { s_->rate_low_levels = std::move(rate); }

void Trainer::State::choose_low_level() {
  const int k = cfg.loop.ll_choice_snapshots;
  if (!rate_low_levels)
    throw io::InputError(run_dir + ": train.ll_choice_snapshots = " + std::to_string(k) +
                         " races the candidate low levels against the autopilot, which `f16race train` does and "
                         "this caller does not; set train.ll_choice_snapshots: 0 here");
  if (world > 1) throw std::logic_error("choose_low_level: a group of ranks (check_tail_members_in_one_process)");
  const auto t = Clock::now();
  const fs::path dir = fs::path(run_dir) / "ll_choice";
  fs::create_directories(dir);
  std::vector<std::string> files, names;
  const std::vector<std::int64_t>& steps = pool.steps();
  const std::size_t older = static_cast<std::size_t>(k - 1);
  for (std::size_t i = steps.size() > older ? steps.size() - older : 0; i < steps.size(); ++i) {
    files.push_back((fs::path(pool.folder(steps[i])) / "ll.pt").string());
    names.push_back(step_name(steps[i]));
  }
  files.push_back((dir / "final_ll.pt").string());  // PpoAgent::save writes it whole or not at all
  names.push_back("final");
  ppo->save(files.back());
  const std::vector<double> winrate = rate_low_levels(files);
  if (winrate.size() != files.size())
    throw std::logic_error("choose_low_level: the rater returned " + std::to_string(winrate.size()) +
                           " winrates for " + std::to_string(files.size()) + " low levels");
  std::size_t pick = 0;
  for (std::size_t i = 1; i < winrate.size(); ++i)
    if (winrate[i] >= winrate[pick]) pick = i;  // a tie goes to the later low level
  std::string csv = "candidate,ll_file,winrate_vs_autopilot,chosen\n";
  for (std::size_t i = 0; i < files.size(); ++i) {
    char rate[32];
    std::snprintf(rate, sizeof rate, "%.6f", winrate[i]);
    csv += names[i] + "," + fs::relative(files[i], run_dir).string() + "," + rate + "," + (i == pick ? "1" : "0") + "\n";
  }
  io::write_file_atomic((dir / "choice.csv").string(), csv);
  // The final one is not reloaded: a run whose choice is its final low level trains the same bytes
  // as without the choice.
  if (pick + 1 != files.size()) ppo->load(files[pick]);
  ll_chosen = true;
  timing.ll_choice += since(t);
}

}  // namespace f16race::train
