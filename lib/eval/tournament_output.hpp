#pragma once
// What a tournament's output folder holds: its file names (the only ones `tournament --out` may
// replace) and done.txt, written last, which says the folder is whole, what was raced and
// whether its figures were drawn. The study counts an interval's tournament as done only when
// done.txt says so for the tournament it wants.
#include <string>
#include <vector>

#include "eval/tournament.hpp"

namespace f16race::eval {

inline constexpr const char* kTournamentMarker = "done.txt";

// Whether `name` is one of a tournament's output files (races.csv, summary.json, the figures,
// their data and scripts, done.txt).
bool is_tournament_output(const std::string& name);

// The options that decide a tournament's races, on one line; runs by their folder names, so the
// same study reached through another spelling of its folder matches.
std::string tournament_marker_options(const TournamentOptions& options);

// Writes DIR/done.txt: the options and "figures: drawn", or the figures that are missing with why.
void write_tournament_marker(const TournamentOptions& options, const std::vector<std::string>& missing_figures,
                             const std::string& dir);

// True when options.out_dir/done.txt records these options with every figure drawn; otherwise
// false with `why` (one line: missing, other options, figures missing).
bool tournament_complete(const TournamentOptions& options, std::string* why = nullptr);

}  // namespace f16race::eval
