// Block events on hand-built end-of-step states: a window opens when an opponent sits in front
// (lead <= 1000 ft, cross-section distance <= 300 ft); it is a block if the one behind is taken
// out or a teammate of the blocker passes it within 5 s; windows expire and reopen; a race's
// last step still counts.
#include <gtest/gtest.h>

#include <array>

#include "race/block_events.hpp"

namespace f16race::race {
namespace {

// One env, 2 vs 2: aircraft 0, 1 blue, 2, 3 red. Blue 0 is the candidate blocker of red 2;
// aircraft 1 and 3 fly far away (2000 ft to the side).
struct World {
  std::array<double, 4> s{5000, 0, 4500, 0}, lat{0, 2000, 100, -2000}, vert{0, 0, 0, 0};
  std::array<std::uint8_t, 4> alive{1, 1, 1, 1};
  std::array<std::int8_t, 4> cause{0, 0, 0, 0};
  std::uint8_t done = 0;
  double t = 0.0;
  BlockCounter counter{1, 4, 2, 0.08};

  void step() {
    t += 0.08;
    BlockStepView v;
    v.n_env = 1;
    v.n_agent = 4;
    v.team_size = 2;
    v.progress_ft = s.data();
    v.lateral_ft = lat.data();
    v.vertical_ft = vert.data();
    v.alive = alive.data();
    v.step_cause = cause.data();
    v.env_done = &done;
    v.race_time_s = &t;
    counter.after_step(v);
    cause.fill(0);
  }
  int blue() const { return counter.race_blocks(0, 0); }
  int red() const { return counter.race_blocks(0, 1); }
};

TEST(BlockEvents, OpponentTakenOutBehindTheBlockerCounts) {
  World w;
  w.step();  // window (0 -> 2) opens
  w.cause[2] = kCauseTube;
  w.alive[2] = 0;
  w.step();
  EXPECT_EQ(w.blue(), 1);
  EXPECT_EQ(w.red(), 0);
  ASSERT_EQ(w.counter.events().size(), 1u);
  const BlockEvent& e = w.counter.events()[0];
  EXPECT_EQ(e.blocker, 0);
  EXPECT_EQ(e.blocked, 2);
  EXPECT_TRUE(e.taken_out);
  EXPECT_NEAR(e.t_open_s, 0.08, 1e-12);
  EXPECT_NEAR(e.t_s, 0.16, 1e-12);
}

TEST(BlockEvents, ATeammatePassingCountsOnlyWhileTheBlockerLeads) {
  World w;
  w.step();
  w.s[1] = 4600.0;  // blue 1 passes red 2 while blue 0 still leads it
  w.step();
  EXPECT_EQ(w.blue(), 1);
  EXPECT_FALSE(w.counter.events()[0].taken_out);
  World x;
  x.step();
  x.s[2] = 5200.0;  // red 2 got past blue 0 first: then blue 1 passing it is no block by 0
  x.s[1] = 5300.0;
  x.step();
  EXPECT_EQ(x.blue(), 0);
  World y;
  y.step();
  y.s[3] = 4600.0;  // red 2's own teammate passing it is not the blocker's team gaining
  y.step();
  EXPECT_EQ(y.blue(), 0);
}

TEST(BlockEvents, OutsideTheGeometryNothingOpens) {
  World w;
  w.lat[2] = 0.0;
  w.vert[2] = 310.0;  // 310 ft away in the cross-section
  w.step();
  w.cause[2] = kCauseCollision;
  w.step();
  EXPECT_EQ(w.blue(), 0);
  World x;
  x.s[2] = 3990.0;  // 1010 ft behind
  x.step();
  x.cause[2] = kCauseCollision;
  x.step();
  EXPECT_EQ(x.blue(), 0);
}

TEST(BlockEvents, WindowsExpireAfterFiveSecondsAndReopen) {
  World w;
  w.step();                                // opens at 0.08 s
  for (int k = 0; k < 62; ++k) w.step();  // 4.96 s after it opened: still open
  w.lat[2] = 1500.0;                       // leaves the blocker's lane
  w.step();                                // 5.04 s after: closed by time, no new window
  w.cause[2] = kCauseTube;
  w.step();
  EXPECT_EQ(w.blue(), 0);
  World x;
  x.step();
  for (int k = 0; k < 62; ++k) x.step();
  x.step();  // the first window closes at 5.12 s and the next opens at once (still in the lane)
  x.step();
  x.cause[2] = kCauseTube;
  x.step();
  EXPECT_EQ(x.blue(), 1);
  ASSERT_EQ(x.counter.events().size(), 1u);
  EXPECT_NEAR(x.counter.events()[0].t_open_s, 5.12, 1e-9);
  World z;  // an outcome one step after the window's end is not a block
  z.step();
  for (int k = 0; k < 62; ++k) z.step();
  z.lat[2] = 1500.0;
  z.cause[2] = kCauseTube;
  z.step();  // 5.04 s after it opened
  EXPECT_EQ(z.blue(), 0);
  World y;  // an event inside the window's last step still counts
  y.step();
  for (int k = 0; k < 61; ++k) y.step();
  y.cause[2] = kCauseTube;
  y.step();  // 4.96 s after it opened
  EXPECT_EQ(y.blue(), 1);
}

TEST(BlockEvents, TheRaceEndingStepCountsAndTheNextRaceStartsAtZero) {
  World w;
  w.step();
  w.step();
  w.cause[2] = kCauseCollision;  // taken out in the step that ended the race
  w.done = 1;
  w.step();
  EXPECT_EQ(w.blue(), 1);
  EXPECT_NEAR(w.counter.events()[0].t_s, 0.24, 1e-12);
  w.done = 0;
  w.t = 0.0;
  w.step();
  EXPECT_EQ(w.blue(), 0);  // the next race
}

}  // namespace
}  // namespace f16race::race
