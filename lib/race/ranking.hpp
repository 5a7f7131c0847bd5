#pragma once
// Ranks and the high-level reward of the paper (Sec. IV-A), as pure functions on one race so
// they can be checked on hand-built positions.
#include <cstdint>

namespace f16race::race {

// ego_rank[a] = number of aircraft strictly ahead of a (0 = leading; ties share a rank). A
// terminated aircraft ranks behind every live one; among the terminated, by their progress.
// team_rank[a] = rank of a's team by its leading member: 0 leading, 1 trailing, 0.5 each on a
// tie (so the team term stays zero-sum). Agents [0, team_size) are team 0 (blue), the rest red.
void compute_ranks(int n_agent, int team_size, const std::uint8_t* alive, const double* progress_ft, int* ego_rank,
                   double* team_rank);

// The team term of r_HL, 1 - 2 lambda_T: +1 leading, -1 trailing, 0 on a tie. An aircraft taken
// out of a race keeps earning it to the race's end (docs/learning.md: elimination never pays).
inline double hl_team_term(double team_rank) { return 1.0 - 2.0 * team_rank; }

// r_HL = (1 - 2 lambda_T) + 0.1 (lambda_E_prev - lambda_E) / (1 + min(lambda_E_prev, lambda_E)).
inline double hl_reward(double team_rank, int prev_ego_rank, int ego_rank) {
  const double lp = prev_ego_rank, lc = ego_rank;
  return hl_team_term(team_rank) + 0.1 * (lp - lc) / (1.0 + (lp < lc ? lp : lc));
}

}  // namespace f16race::race
