#pragma once
// Reward scaling for PPO by the spread of the discounted return (gym's NormalizeReward, which
// CleanRL's continuous-action PPO wraps around its envs): every reward is divided by the running
// standard deviation of G_t = gamma G_{t-1} + r_t, kept per sample column and restarted when the
// column's episode ends. The mean is not subtracted: a constant added to every reward would
// change which policy is best in a task with terminations. Unlike gym, the statistics take a
// rollout's returns in one merge at its end, and that rollout's rewards are scaled by the result.
#include <cstdint>
#include <vector>

namespace f16race::agents {

class ReturnScaler {
 public:
  // What a checkpoint keeps (all of it, so a resumed run scales as an unbroken one).
  struct Stats {
    std::vector<double> g;  // [columns] discounted return so far of each column's episode
    double count = 0.0, mean = 0.0, m2 = 0.0;              // every return merged so far (Welford)
    double batch_count = 0.0, batch_mean = 0.0, batch_m2 = 0.0;  // this rollout's, not merged yet
  };

  ReturnScaler() = default;
  ReturnScaler(std::int64_t columns, double gamma);

  // Column k's reward of one step. `valid`: the sample counts (the aircraft acted, the learner's
  // low level flew it); an invalid one restarts the column. `ended`: its episode ended here.
  void observe(std::int64_t k, double reward, bool valid, bool ended);
  // Merges this rollout's returns into the running statistics and returns the factor for its
  // rewards, 1 / sqrt(var + 1e-8) (population variance); 1 before any return was seen.
  double end_rollout();

  Stats& stats() { return s_; }
  const Stats& stats() const { return s_; }

 private:
  double gamma_ = 0.99;
  Stats s_;
};

}  // namespace f16race::agents
