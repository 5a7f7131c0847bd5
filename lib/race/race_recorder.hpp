#pragma once
// Records the first race of every env of a RaceEnv (trajectories, HL goals, how it ended) and
// writes it out: one CSV per aircraft, the goals, the track, a figure in the style of the
// paper's Fig. 4/5 (forward displacement vs lateral offset and vs height in the tube, tube
// boundary drawn, teams coloured, HL goals marked) and a Tacview .acmi file.
//
//   RaceRecorder rec(env);
//   loop: due = copy of env.hl_due(); env.set_hl_actions(bins); rec.record_goals(env, due);
//         rec.before_step(env); env.step(actions); rec.after_step(env);   until rec.remaining() == 0
#include <cstdint>
#include <string>
#include <vector>

#include "race/block_events.hpp"
#include "race/race_env.hpp"
#include "race/track.hpp"

namespace f16race::race {

struct TraceRow {
  double t_s, s_ft, lateral_ft, vertical_ft;  // race time, progress and tube offsets
  double pn_ft, pe_ft, alt_ft;                // position (north, east, altitude)
  double vt_ftps, phi_rad, theta_rad, psi_rad;
  double radius_ft;                           // tube radius at s
  // The step's throttle: as the policy commanded it (0..1) and as flown after the Mach governor,
  // and what it made: engine power and angle of attack (a speed deficit is throttle or drag).
  double throttle_cmd, throttle, power_pct, alpha_rad;
};

struct GoalMark {
  double t_s;                            // decision time
  double s_ft, lateral_ft, vertical_ft;  // the goal point in track coordinates
  Vec3 point;                            // and in the world
  std::int64_t bins[kHlDims];            // the HL bins it was placed with (x, y, z of goal_frame)
};

struct RaceTrace {
  Track track;  // the course raced
  int team_size = 0;
  int middle_bin = 0;                         // the HL's middle bin per axis (RaceConfig::hl_center_bin)
  std::vector<std::vector<TraceRow>> rows;    // [agent][step]
  std::vector<std::vector<GoalMark>> goals;   // [agent][decision]
  std::vector<int> cause;                     // [agent] termination cause (kCauseNone: finished alive)
  std::vector<double> out_s;                  // [agent] race time when terminated, -1 if never
  bool done = false;
  int winner = -1;                            // 0 blue, 1 red, -1 draw
  int end = 0;                                // RaceEnv::EndReason
  double duration_s = 0.0;
};

class RaceRecorder {
 public:
  explicit RaceRecorder(const RaceEnv& env);
  // After set_hl_actions; `due` is env.hl_due() as it was before that call. `agents` [n_agent]
  // (optional) selects whose goals to keep, e.g. not those of pilots that ignore goals.
  void record_goals(const RaceEnv& env, const std::uint8_t* due, const std::uint8_t* agents = nullptr);
  void before_step(const RaceEnv& env);
  void after_step(const RaceEnv& env);
  int remaining() const { return remaining_; }
  const RaceTrace& trace(int env) const { return traces_[env]; }

 private:
  void record_rows(const RaceEnv& env, int e);
  std::vector<RaceTrace> traces_;
  std::vector<double> t_before_;
  int remaining_ = 0;
};

const char* end_reason_name(int end);

// PREFIX_agentK.csv, PREFIX_goals.csv, PREFIX_track.csv and PREFIX_tube.csv in `dir`.
void write_trace_csv(const RaceTrace& trace, const std::string& dir, const std::string& prefix);
// PREFIX_blocks.csv: each block (race/block_events.hpp) with where the blocker and the blocked
// aircraft were (progress, lateral, vertical) when its window opened.
void write_blocks_csv(const RaceTrace& trace, const std::vector<BlockEvent>& blocks, const std::string& dir,
                      const std::string& prefix);
// PREFIX.png (+ PREFIX.gp) from the CSVs above; with blocks (written by write_blocks_csv) it marks
// each block where its window opened: a filled square at the blocker in its team's colour, a
// cross at the aircraft it held up. Returns false with `message` if gnuplot is missing.
bool plot_trace(const RaceTrace& trace, const std::string& dir, const std::string& prefix, const std::string& title,
                std::string* message, const std::vector<BlockEvent>& blocks = {});
// Aircraft (team colours and coalitions), their HL goals, and center-line markers every 2 000 ft.
void write_trace_acmi(const RaceTrace& trace, const std::string& path, const std::string& title,
                      const std::vector<std::string>& team_names = {"Blue", "Red"});

}  // namespace f16race::race
