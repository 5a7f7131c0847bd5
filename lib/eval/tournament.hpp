#pragma once
// Round-robin tournaments between trained runs (and a built-in untrained entry), raced in large
// batches on the batched simulator with both teams acting greedily. Optional control entries fly
// a run's trained low level under a fixed high level, to show what the high level adds.
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include "race/race_env.hpp"
#include "random/random_stream.hpp"

namespace f16race::dist {
class Group;
}

namespace f16race::eval {

// Where a team's HL goal bins come from: its run's trained HL policy, or a fixed rule.
enum class HlOverride {
  none,    // the run's HL policy (greedy unless --epsilon)
  center,  // the middle bin (hl_bins / 2) on every axis: goals on the center-line
  random,  // uniform random bins per aircraft and axis at each HL decision
  // The run's HL policy with one goal axis (x, y, z of race.goal_frame; track: along, right, up)
  // held on the middle bin: is the critic right to avoid the middle there?
  center_x,
  center_y,
  center_z,
};

// "policy", "center", "random", "center_x", "center_y", "center_z"; the suffix of a control
// entry's name is "@" + this name.
const char* hl_override_name(HlOverride rule);
// How reports describe the rule ("policy", "fixed: middle bin", ...).
const char* hl_override_description(HlOverride rule);
// Whether the rule keeps the run's HL policy (none and the one-axis rules) before fixing bins.
bool hl_override_uses_policy(HlOverride rule);
// Every rule but none, in the order of the enum (entry specs, report columns).
const std::vector<HlOverride>& hl_override_rules();

// Splits an entry spec "RUN@<rule>" (a name above) into the run folder and the rule; any other
// spec (including one with another "@...") is a plain run folder with HlOverride::none.
std::pair<std::string, HlOverride> parse_entry_spec(const std::string& spec);

// The one place fixed HL rules are applied: writes the bins of `n_aircraft` aircraft (3 axes
// each, aircraft-major) into `out`. center: hl_bins / 2 everywhere, `rng` untouched; random:
// uniform in [0, hl_bins), three draws per aircraft from `rng` in aircraft order; center_x/y/z:
// hl_bins / 2 on that axis only, the other axes (the policy's, written before) untouched. `rule`
// must not be none (that is the run's policy).
void fixed_hl_bins(HlOverride rule, int hl_bins, int n_aircraft, RandomStream& rng, std::int64_t* out);

// The random stream of the @random rule in race `race` of each pairing of a tournament (or in a
// replay, race 0) seeded `seed`: independent of the track streams, and of the thread count
// (drawn serially, per race).
RandomStream control_stream(std::uint64_t seed, int race);

// The stream id (under the tournament's track seed) that draws track `track` and its start:
// race r of every pairing is flown on track r / 2.
std::uint64_t track_stream_id(int track);

struct TournamentOptions {
  std::vector<std::string> runs;  // run folders written by `f16race train`
  bool include_untrained = true;  // adds the entry "untrained": the networks before any update
  bool untrained_in_statistics = false;  // counts "untrained" in the per-variant statistics
  bool controls = false;          // adds RUN@center and RUN@random for every run
  bool axis_controls = false;     // adds RUN@center_x, @center_y, @center_z for every run
  // Each control entry races its own run alone (not the other entries, nor the other controls):
  // the head-to-heads that ask what a high level adds, at a fraction of the races.
  bool controls_own_run = false;
  bool include_autopilot = false;  // adds "autopilot": AeroBench's waypoint autopilot, no learning
  double autopilot_airspeed_ftps = 0.0;  // its set point; 0: the first run's race.autopilot_airspeed_ftps
  // The autopilot's start lanes shifted onto each race's racing line (the race's goal_line_frac,
  // which must be > 0), its aim points held within 0.8 of the radius: the classic pilot given the
  // line the learned team's goals are placed around.
  bool autopilot_on_line = false;
  // The autopilot's aim points moved up by this fraction of the local radius (negative: down),
  // held within 0.8 of it; NaN: the first run's race.autopilot_shift_up_frac.
  double autopilot_shift_up_frac = std::numeric_limits<double>::quiet_NaN();
  // Non-empty: race on this config file's tracks (race.track) and time limit (race.time_limit_s)
  // instead of the first run's, e.g. trained runs on configs/long.yaml's long tracks.
  std::string tracks_config;
  // >= 0: every entry's goals placed around the racing line of this radius fraction
  // (race.goal_line_frac; 0: the center-line) instead of the first run's setting.
  double goal_line_frac = -1.0;
  // NaN: the first run's race.goal_shift_up_frac; else every entry's goals moved up by this
  // fraction of the radius (negative: down).
  double goal_shift_up_frac = std::numeric_limits<double>::quiet_NaN();
  int races_per_pair = 64;        // half with each side
  std::uint64_t seed = 1;         // tracks and starting positions, and the @random streams
  double epsilon = 0.0;           // HL exploration during evaluation
  int batch_envs = 256;           // races run at once
  int bootstrap_replicates = 2000;
  std::string out_dir;
  // Non-empty: the races so far are kept in this file (eval/tournament_journal.hpp), and a
  // tournament stopped before its end goes on from it. Used by one process with greedy HL only
  // (epsilon 0): a group's or an exploring tournament's races depend on the batch.
  std::string journal_path;
};

// The autopilot entry's height shift: the option when given, else the race's.
inline double autopilot_shift_up(const TournamentOptions& o, const race::RaceConfig& rc) {
  return std::isnan(o.autopilot_shift_up_frac) ? rc.autopilot_shift_up_frac : o.autopilot_shift_up_frac;
}

struct Entry {
  std::string name;     // folder name, "untrained", or "<run name>@center" / "@random"
  std::string path;
  std::string variant;  // es, es_d1, es_d2, es_d3 (the untrained entry: "untrained", the
                        // autopilot "autopilot"); a control entry keeps its run's variant
  std::uint64_t seed = 0;
  HlOverride hl = HlOverride::none;  // control entries: the fixed HL rule
  int policy = 0;                    // index of the loaded policy it flies (controls share their run's;
                                     // -1: the autopilot, no network)
};

inline bool is_control(const Entry& e) { return e.hl != HlOverride::none; }
inline bool is_untrained(const Entry& e) { return e.variant == "untrained" && !is_control(e); }
inline bool is_autopilot(const Entry& e) { return e.policy < 0; }
// Whether the entry's games count in the per-variant statistics (and the variant-vs-variant
// panel): trained runs always, "untrained" only with options.untrained_in_statistics, control
// entries and the autopilot never.
bool in_variant_statistics(const Entry& entry, const TournamentOptions& options);

// RaceRecord's goal choices: below, on and above the middle bin on each of the HL's axes.
inline constexpr int kChoiceFields = 3 * race::kHlDims;

struct RaceRecord {
  int pair = 0, blue = 0, red = 0;  // entry indices
  int race = 0;                     // index in its pairing: even races blue = the lower entry
  // The track and start: drawn by a RaceEnv seeded track_seed from stream track_stream_id(track),
  // track = race / 2 (each track flown from both sides). `env`: the env slot that raced it.
  std::uint64_t track_seed = 0;
  int track = 0;
  int env = 0;
  int winner = -1;                  // entry index, -1 draw
  int end_reason = 0;               // RaceEnv::EndReason
  double duration_s = 0.0;
  // Aircraft each team lost, per race::TerminationCause (index kCauseNone unused).
  std::array<int, race::kNumCauses> blue_lost{}, red_lost{};
  int blue_out() const { return std::accumulate(blue_lost.begin(), blue_lost.end(), 0); }
  int red_out() const { return std::accumulate(red_lost.begin(), red_lost.end(), 0); }
  int blue_blocks = 0, red_blocks = 0;  // blocks by each team (race/block_events.hpp)
  // Each team's high-level goal choices over the race: per goal axis (x, y, z of race.goal_frame;
  // track: along, right, up), how many decisions of its living aircraft took a bin below, on or
  // above the middle bin, at [axis * 3 + {0, 1, 2}]. Does a high level win by height, or width?
  std::array<int, kChoiceFields> blue_choices{}, red_choices{};
};

struct TournamentResult {
  std::vector<Entry> entries;  // runs in --runs order, then "untrained", "autopilot", the controls
  std::vector<RaceRecord> races;
  race::RaceConfig race;  // what the races were run with (the first run's, or --tracks' tracks)
  // wins[i][j]: races entry i won against j (draws count half); games[i][j]: races played.
  std::vector<std::vector<double>> wins, games;
  // "" when every run was trained in one numeric mode (io/numeric_mode.hpp) and, if native, on one
  // CPU; otherwise one line naming each run's mode: their winrates then compare kernels too.
  std::string numerics_note;
};

// Runs every pair; `progress(done, total)` after each batch; `say` gets one line about the
// journal (races kept, or why it was started anew). Throws io::InputError with the
// run folder named when a run is missing, corrupt, or trained on a different race shape.
// With a `group` of W ranks each rank races its share of the batch's envs (a contiguous slice,
// its own streams under the same ids), the ranks step in lockstep and agree on which env takes
// the next game from which races ended where, and every rank returns the whole result: the same
// races, bit for bit, as one process (greedy HL, `epsilon` 0; per-row network outputs do not
// depend on the batch they come in, which the test holds).
TournamentResult run_tournament(const TournamentOptions& options,
                                const std::function<void(long, long)>& progress = {},
                                dist::Group* group = nullptr,
                                const std::function<void(const std::string&)>& say = {});

// Its outputs (summary tables, CSVs, figures): eval/tournament_report.hpp.

}  // namespace f16race::eval
