// Self-play: who each race's learner team meets (the current policy, a pool snapshot, or the
// center line in the tail), and the pool of snapshots opponents are drawn from.
#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "dist/process_group.hpp"
#include "io/atomic_file.hpp"
#include "train/trainer_state.hpp"

namespace f16race::train {

namespace fs = std::filesystem;

Matchup draw_matchup(RandomStream& stream, const PoolConfig& pool, bool pool_available, bool in_tail) {
  Matchup m;
  // Both numbers are always drawn, so the stream advances the same way whatever the settings.
  const double u_side = stream.uniform(), u_pool = stream.uniform();
  m.learner_side = pool.randomize_sides && u_side < 0.5 ? 1 : 0;
  // u_pool below p_center: the center-line control; above it, self-play or pool in the odds
  // p_self_play gives (outside the tail, p_center 0: the paper's draws).
  const double p_center = in_tail ? pool.p_center_tail : 0.0;
  m.vs_center = u_pool < p_center;
  m.vs_pool = !m.vs_center && pool_available && u_pool >= p_center + (1.0 - p_center) * pool.p_self_play;
  return m;
}

std::size_t draw_pool_entry(RandomStream& stream, std::size_t n) {
  return std::min(n - 1, static_cast<std::size_t>(stream.uniform() * static_cast<double>(n)));
}

void Trainer::State::draw_matchup(int e) {
  // The tail's races are those that start after the low level's last update (the step count
  // crosses the switch inside an update): its last update keeps the bilevel part's matchups.
  const Matchup m = train::draw_matchup(stream, cfg.pool, opponent >= 0, in_frozen_tail());
  side[e] = m.learner_side;
  vs_pool[e] = m.vs_center ? kVsCenter : (m.vs_pool ? kVsPool : kVsSelf);
}

void Trainer::State::snapshot_pool() {
  pool.add(env_steps, opponent, [&](const std::string& dir) {
    ppo->save(dir + "/ll.pt");
    es->save(dir + "/hl.pt");
  });
}

void Trainer::State::load_opponent() {
  if (pool.empty()) {
    opponent = -1;
    return;
  }
  std::vector<std::int64_t> pick{static_cast<std::int64_t>(draw_pool_entry(stream, pool.steps().size()))};
  if (group != nullptr) {  // rank 0's draw for the group (every rank draws: streams advance alike)
    if (!writes()) pick[0] = 0;
    group_sum(pick);
  }
  opponent = pool.steps()[static_cast<std::size_t>(pick[0])];
  load_pool_snapshot();
}

void Trainer::State::load_pool_snapshot() {
  const fs::path dir = pool.folder(opponent);
  if (group == nullptr) {
    opp_ppo->load((dir / "ll.pt").string());
    opp_es->load((dir / "hl.pt").string());
    return;
  }
  // Rank 0 holds the pool; the others get the snapshot's bytes.
  std::string ll, hl;
  if (writes()) ll = io::read_file((dir / "ll.pt").string()), hl = io::read_file((dir / "hl.pt").string());
  group->broadcast_bytes(ll);
  group->broadcast_bytes(hl);
  opp_ppo->load_bytes(ll);
  opp_es->load_bytes(hl);
}

}  // namespace f16race::train
