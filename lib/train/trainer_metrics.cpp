// The trainer's metrics rows (RUN/metrics.csv, one per update): accumulated over the rollout,
// summed over a group's ranks, appended by rank 0, and cut back to a checkpoint at a resume.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iterator>
#include <string>
#include <vector>

#include "io/atomic_file.hpp"
#include "train/metrics_file.hpp"
#include "train/trainer_state.hpp"

namespace f16race::train {

namespace fs = std::filesystem;

MetricsRow Trainer::State::make_row(const char* phase_name) {
  if (group != nullptr) {
    // The group's row: every rank's races and returns.
    std::vector<double> acc{sum_ll_ret, sum_hl_ret, n_ret, n_hl_ret, sum_goal, n_goal, sum_vt, n_vt, races, wins, finishes};
    acc.insert(acc.end(), std::begin(term), std::end(term));
    group_sum(acc);
    std::size_t k = 0;
    for (double* x : {&sum_ll_ret, &sum_hl_ret, &n_ret, &n_hl_ret, &sum_goal, &n_goal, &sum_vt, &n_vt, &races, &wins, &finishes})
      *x = acc[k++];
    for (double& t : term) t = acc[k++];
  }
  MetricsRow r;
  r.update = ppo_updates + es_updates;
  r.phase = phase_name;
  r.env_steps = env_steps;
  r.wall_s = wall();
  const double dt = std::max(r.wall_s - wall_at_row, 1e-9);
  r.samples_per_s = static_cast<double>(env_steps - steps_at_row) * n_agent / dt;
  r.ll_return = n_ret > 0 ? sum_ll_ret / n_ret : std::nan("");
  r.hl_return = n_hl_ret > 0 ? sum_hl_ret / n_hl_ret : std::nan("");
  r.goal_dist_ft = n_goal > 0 ? sum_goal / n_goal : std::nan("");
  r.airspeed_ftps = n_vt > 0 ? sum_vt / n_vt : std::nan("");
  r.races = races;
  r.winrate = races > 0 ? wins / races : std::nan("");
  r.finish_rate = races > 0 ? finishes / races : std::nan("");
  for (int k = 1; k < race::kNumCauses; ++k) r.term[k] = races > 0 ? term[k] / races : std::nan("");
  r.policy_loss = last_ppo.policy_loss;
  r.value_loss = last_ppo.value_loss;
  r.entropy = last_ppo.entropy;
  r.approx_kl = last_ppo.approx_kl;
  r.lr = last_ppo.learning_rate;
  r.es_loss = last_es.loss;
  r.q_mean = last_es.q_mean;
  r.epsilon = cfg.hl.epsilon;
  r.hl_grad_steps = hl_grad_steps;
  if (es_updates > 0) {
    r.es_loss_heldout = last_es.loss_before;
    r.es_end_atom_share = last_es.end_atom_share;
    r.es_huber_share = last_es.huber_share;
    r.q_spread = last_es.q_spread;
    r.greedy_entropy = last_es.greedy_entropy;
    r.off_center_share = last_es.off_center_share;
    r.middle_share = last_es.middle_share;
  }
  sum_ll_ret = sum_hl_ret = n_ret = n_hl_ret = sum_goal = n_goal = sum_vt = n_vt = races = wins = finishes = 0;
  std::fill(std::begin(term), std::end(term), 0.0);
  steps_at_row = env_steps;
  wall_at_row = r.wall_s;
  return r;
}

void Trainer::State::write_row(const MetricsRow& r) {
  if (!writes()) return;
  // Appended line by line: a crash loses at most the row being written, and resume drops rows
  // past the checkpoint it continues from.
  const std::string path = run_dir + "/metrics.csv";
  io::append_file(path, (fs::exists(path) ? std::string() : metrics_header_line() + "\n") + metrics_csv_line(r));
}

void Trainer::State::truncate_metrics() {
  // Rows written after this checkpoint go (the resumed run writes them again).
  const std::string mpath = run_dir + "/metrics.csv";
  if (!fs::exists(mpath)) return;
  io::write_file_atomic(mpath, metrics_kept_up_to(io::read_file(mpath), ppo_updates + es_updates, mpath));
}

}  // namespace f16race::train
