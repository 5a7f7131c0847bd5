#pragma once
// Blocks: a measured team interaction (issue 14), checkable in a replay figure. Aircraft B
// *sits in front of* opponent O when both are alive, B leads O along the track by at most
// kBlockAheadFt and their offsets in the tube's cross-section are within kBlockRadiusFt of each
// other: B is in O's way. From the first step this holds, a window of kBlockWindowS opens; the
// pair counts as a *block* if within it O is taken out (any cause: a collision, the tube, its
// envelope) or loses a place to B's team (one more live teammate of B gets ahead of O) while B
// still leads it: B holds O up while a teammate passes. One block at most per window: after a
// block the pair's next window can open from the next step, after an expired one at once.
// Checked at the end of every LL step.
#include <cstdint>
#include <vector>

#include "race/race_env.hpp"

namespace f16race::race {

inline constexpr double kBlockAheadFt = 1000.0;
inline constexpr double kBlockRadiusFt = 300.0;
inline constexpr double kBlockWindowS = 5.0;

// The end-of-step state the counter reads, [n_env, n_agent] unless noted (tests build their own).
struct BlockStepView {
  int n_env = 0, n_agent = 0, team_size = 0;  // aircraft 0..team_size-1 are blue
  const double* progress_ft = nullptr;
  const double* lateral_ft = nullptr;    // offsets in the tube's cross-section
  const double* vertical_ft = nullptr;
  const std::uint8_t* alive = nullptr;
  const std::int8_t* step_cause = nullptr;  // TerminationCause of this step
  const std::uint8_t* env_done = nullptr;   // [n_env]: this step ended the race (state: the next race)
  const double* race_time_s = nullptr;      // [n_env]
};

BlockStepView block_view(const RaceEnv& env);

struct BlockEvent {
  int env = 0;
  int blocker = 0, blocked = 0;  // aircraft indices in the env (agent order)
  double t_open_s = 0.0;         // race time the window opened
  double t_s = 0.0;              // race time of the outcome
  bool taken_out = false;        // true: the blocked aircraft was taken out; false: a teammate of the blocker passed it
};

class BlockCounter {
 public:
  BlockCounter(int n_env, int n_agent, int team_size, double dt_ll_s);
  explicit BlockCounter(const RaceEnv& env);
  // After every env step. For an env whose race just ended (env_done) the blocks of that race are
  // final: read them with race_blocks() before the next call.
  void after_step(const BlockStepView& v);
  // Blocks by team `team` (0 blue, 1 red) in env e's current race; after a step that ended the
  // race, in the race that ended.
  int race_blocks(int env, int team) const { return blocks_[2 * env + team]; }
  // Every block so far, in the order they happened (for replays; tournaments read the counts).
  const std::vector<BlockEvent>& events() const { return events_; }

 private:
  int n_env_, n_agent_, ts_;
  double dt_s_;
  // Per env and ordered opponent pair (B, O): [n_env, n_agent, n_agent].
  std::vector<double> open_at_s_;  // race time the window opened, < 0: no window
  std::vector<int> ahead_at_open_;  // live aircraft of B's team ahead of O when the window opened
  std::vector<int> blocks_;          // [n_env, 2]
  std::vector<std::uint8_t> ended_;  // [n_env]: the last step ended this env's race
  std::vector<double> last_t_s_;     // [n_env]: race time after the last step of the current race
  std::vector<BlockEvent> events_;
};

}  // namespace f16race::race
