// The end of one env's race: a finish line crossed, a whole team out, or the time limit. The
// outcome goes into the env's outputs and stats, the survivors' episodes end (terminated, or
// truncated at a non-terminal time limit, with their final observations kept) and the env starts
// its next race.
#include "race/race_env.hpp"

namespace f16race::race {

bool RaceEnv::end_race_if_over(int e) {
  const RaceConfig& c = config_;
  const int base = e * n_agent_;
  bool finished = false;
  int team_alive[2] = {0, 0};
  for (int a = 0; a < n_agent_; ++a) {
    const int i = base + a;
    team_alive[team_of(a, c.team_size)] += alive_[i];
    finished = finished || (alive_[i] && progress_ft_[i] >= tracks_[e].length_ft() - c.finish_margin_ft);
  }
  const bool eliminated = team_alive[0] == 0 || team_alive[1] == 0;
  const bool timeout = time_s_[e] >= c.time_limit_s - 1e-9;
  env_done_[e] = finished || eliminated || timeout;
  if (!env_done_[e]) return false;
  StepStats& st = step_stats_[e];
  st.races_finished = 1;
  const double tr_blue = team_rank_[base];
  if (tr_blue == 0.0) st.races_won[0] = 1;
  else if (tr_blue == 1.0) st.races_won[1] = 1;
  else st.races_drawn = 1;
  st.races_by_finish_line = finished;
  st.races_by_elimination = !finished && eliminated;
  st.races_by_time_limit = !finished && !eliminated;
  race_winner_[e] = static_cast<std::int8_t>(tr_blue == 0.0 ? 0 : (tr_blue == 1.0 ? 1 : -1));
  race_end_[e] = finished ? kEndFinishLine : (eliminated ? kEndElimination : kEndTimeLimit);
  for (int a = 0; a < n_agent_; ++a) {
    const int i = base + a;
    if (!alive_[i]) continue;
    st.aircraft_alive_at_end += 1;
    if (finished || eliminated || c.time_limit_terminal) terminated_[i] = 1;
    else truncated_[i] = 1;
  }
  if (st.races_by_time_limit && !c.time_limit_terminal) {
    write_observations(e);
    copy_final_observations(e);
  }
  reset_env(e);
  return true;
}

}  // namespace f16race::race
