#pragma once
// Round-robin tournaments between trained runs (and a built-in untrained entry), raced in large
// batches on the batched simulator with both teams acting greedily.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace f16race::eval {

struct TournamentOptions {
  std::vector<std::string> runs;  // run folders written by `f16race train`
  bool include_untrained = true;  // adds the entry "untrained": the networks before any update
  int races_per_pair = 64;        // half with each side
  std::uint64_t seed = 1;         // tracks and starting positions
  double epsilon = 0.0;           // HL exploration during evaluation
  int batch_envs = 256;           // races run at once
  int bootstrap_replicates = 2000;
  std::string out_dir;
};

struct Entry {
  std::string name;     // folder name, or "untrained"
  std::string path;
  std::string variant;  // es, es_d1, es_d2, es_d3 (the untrained entry: "untrained")
  std::uint64_t seed = 0;
};

struct RaceRecord {
  int pair = 0, blue = 0, red = 0;  // entry indices
  // The track and start: race number race_in_env of env `env` of a RaceEnv seeded track_seed.
  std::uint64_t track_seed = 0;
  int env = 0;
  int race_in_env = 0;
  int winner = -1;                  // entry index, -1 draw
  int end_reason = 0;               // RaceEnv::EndReason
  double duration_s = 0.0;
  int blue_out = 0, red_out = 0;    // aircraft terminated per team
};

struct TournamentResult {
  std::vector<Entry> entries;
  std::vector<RaceRecord> races;
  // wins[i][j]: races entry i won against j (draws count half); games[i][j]: races played.
  std::vector<std::vector<double>> wins, games;
};

// Runs every pair; `progress(done, total)` after each batch. Throws std::runtime_error with the
// run folder named when a run is missing, corrupt, or trained on a different race shape.
TournamentResult run_tournament(const TournamentOptions& options,
                                const std::function<void(long, long)>& progress = {});

// Writes races.csv, pairings.csv, summary.json, summary.md and the three figures into out_dir.
void write_tournament_report(const TournamentResult& result, const TournamentOptions& options);

}  // namespace f16race::eval
