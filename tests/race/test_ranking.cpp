// Ranks and the HL reward formula on hand-built positions.
#include <gtest/gtest.h>

#include <cstdint>

#include "race/ranking.hpp"

namespace f16race::race {
namespace {

TEST(Ranking, EgoRanksCountAircraftStrictlyAhead) {
  // 2 vs 2: blue 0, 1; red 2, 3.
  const std::uint8_t alive[4] = {1, 1, 1, 1};
  const double s[4] = {1000, 3000, 2000, 500};
  int ego[4];
  double team[4];
  compute_ranks(4, 2, alive, s, ego, team);
  EXPECT_EQ(ego[0], 2);
  EXPECT_EQ(ego[1], 0);
  EXPECT_EQ(ego[2], 1);
  EXPECT_EQ(ego[3], 3);
  EXPECT_EQ(team[0], 0.0);  // blue leads through aircraft 1
  EXPECT_EQ(team[3], 1.0);
}

TEST(Ranking, DeadAircraftRankBehindEveryLiveOne) {
  const std::uint8_t alive[4] = {0, 1, 1, 0};
  const double s[4] = {9000, 100, 200, 8000};  // the dead were far ahead when they went out
  int ego[4];
  double team[4];
  compute_ranks(4, 2, alive, s, ego, team);
  EXPECT_EQ(ego[2], 0);
  EXPECT_EQ(ego[1], 1);
  EXPECT_EQ(ego[0], 2);  // dead, but further than the other dead one
  EXPECT_EQ(ego[3], 3);
  EXPECT_EQ(team[2], 0.0);  // red leads
  EXPECT_EQ(team[0], 1.0);
}

TEST(Ranking, TiesShareARankAndATeamTieIsHalf) {
  const std::uint8_t alive[4] = {1, 1, 1, 1};
  const double s[4] = {5000, 1000, 5000, 1000};
  int ego[4];
  double team[4];
  compute_ranks(4, 2, alive, s, ego, team);
  EXPECT_EQ(ego[0], 0);
  EXPECT_EQ(ego[2], 0);
  EXPECT_EQ(ego[1], 2);
  EXPECT_EQ(ego[3], 2);
  for (double t : team) EXPECT_EQ(t, 0.5);
  EXPECT_EQ(hl_reward(0.5, 0, 0), 0.0);
}

TEST(Ranking, HlRewardFollowsThePaper) {
  // Leading team, ego moved from rank 3 to rank 1: 1 + 0.1 * 2 / (1 + 1).
  EXPECT_DOUBLE_EQ(hl_reward(0.0, 3, 1), 1.0 + 0.1);
  // Trailing team, ego dropped from 0 to 2: -1 + 0.1 * (-2) / 1.
  EXPECT_DOUBLE_EQ(hl_reward(1.0, 0, 2), -1.0 - 0.2);
  // Unchanged rank: the team term only.
  EXPECT_DOUBLE_EQ(hl_reward(0.0, 2, 2), 1.0);
}

TEST(Ranking, TeamTermIsZeroSumAndSwapsAreZeroSum) {
  const std::uint8_t alive[8] = {1, 1, 1, 1, 1, 1, 1, 1};
  const double before[8] = {10, 20, 30, 40, 50, 60, 70, 80};
  const double after[8] = {10, 20, 30, 40, 50, 60, 80, 70};  // red 6 and 7 swap places
  int r0[8], r1[8];
  double t0[8], t1[8];
  compute_ranks(8, 4, alive, before, r0, t0);
  compute_ranks(8, 4, alive, after, r1, t1);
  double total = 0.0;
  for (int a = 0; a < 8; ++a) total += hl_reward(t1[a], r0[a], r1[a]);
  EXPECT_NEAR(total, 0.0, 1e-12);
}

}  // namespace
}  // namespace f16race::race
