#include "race/ranking.hpp"

namespace f16race::race {

void compute_ranks(int n_agent, int team_size, const std::uint8_t* alive, const double* progress_ft, int* ego_rank,
                   double* team_rank) {
  for (int a = 0; a < n_agent; ++a) {
    int ahead = 0;
    for (int b = 0; b < n_agent; ++b) {
      if (b == a) continue;
      ahead += alive[b] != alive[a] ? alive[b] != 0 : progress_ft[b] > progress_ft[a];
    }
    ego_rank[a] = ahead;
  }
  int lead[2] = {n_agent, n_agent};
  for (int a = 0; a < n_agent; ++a) {
    const int t = a < team_size ? 0 : 1;
    lead[t] = ego_rank[a] < lead[t] ? ego_rank[a] : lead[t];
  }
  const double blue = lead[0] < lead[1] ? 0.0 : (lead[0] > lead[1] ? 1.0 : 0.5);
  for (int a = 0; a < n_agent; ++a) team_rank[a] = a < team_size ? blue : 1.0 - blue;
}

}  // namespace f16race::race
