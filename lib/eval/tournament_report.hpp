#pragma once
// A tournament's outputs: what they say, computed once (tournament_statistics: winrates, Wilson
// intervals, per-variant mean, std and IQM with its bootstrap CI, variant vs variant), and one
// writer per output file. Torch-free: it reads a TournamentResult, however it was raced.
#include <array>
#include <string>
#include <vector>

#include "eval/statistics.hpp"
#include "eval/tournament.hpp"

namespace f16race::eval {

// One variant over the entries counted in the statistics (no controls; "untrained" only with
// untrained_in_statistics), against every counted entry of the other variants.
struct VariantRow {
  std::string variant;
  int runs = 0;
  double mean = 0.0, std = 0.0;  // total winrate over its runs (seeds)
  Interval iqm;                  // IQM of run x opponent winrates, stratified-bootstrap 95 % CI
  double races = 0.0;
  double blocks_per_race = 0.0;  // blocks by the variant's runs in all their races / those races
};

struct TournamentStatistics {
  std::vector<std::vector<double>> rate;          // [entry][entry] row's winrate vs column, NaN: not raced
  std::vector<double> entry_races, entry_blocks;  // [entry] over all its races
  // [entry] its teams' HL goal choices summed over its races (RaceRecord::blue_choices' layout)
  std::vector<std::array<double, kChoiceFields>> entry_choices;
  std::vector<Interval> entry_rate;               // [entry] vs all other entries, Wilson 95 %
  std::vector<bool> counted;                      // [entry] in the variant statistics
  std::vector<std::string> excluded;              // the entries not counted, by name
  std::vector<VariantRow> rows;                   // variants with another variant to compare with
  std::vector<std::string> variants;              // every counted variant, sorted
  std::vector<std::vector<double>> variant_rate;  // [variant][variant] mean pairing winrate, NaN: none
  std::vector<std::vector<int>> variant_pairs;    // [variant][variant] pairings in that mean
};

TournamentStatistics tournament_statistics(const TournamentResult& result, const TournamentOptions& options);

void write_races_csv(const TournamentResult& result, const std::string& path);
void write_pairings_csv(const TournamentResult& result, const TournamentStatistics& s, const std::string& path);
void write_summary_json(const TournamentResult& result, const TournamentStatistics& s,
                        const TournamentOptions& options, const std::string& path);
std::string summary_markdown(const TournamentResult& result, const TournamentStatistics& s,
                             const TournamentOptions& options);
// tournament.png in the layout of the paper's Fig. 3 (bars with std, IQM with CI, variant vs
// variant) and pairings.png (entry vs entry), with their data and gnuplot scripts. Returns the
// figures not drawn, each "NAME.png (why)"; their data and scripts are written all the same.
std::vector<std::string> write_tournament_figures(const TournamentResult& result, const TournamentStatistics& s,
                                                  const std::string& out_dir);

// All of the above into options.out_dir: races.csv, pairings.csv, summary.json, summary.md and
// the figures, then done.txt (eval/tournament_output.hpp). Returns summary.md's text, for the
// caller to print, and the figures not drawn in `missing_figures`. The folder is written in
// place: `tournament` writes it into an io::StagedFolder, so it appears whole.
std::string write_tournament_report(const TournamentResult& result, const TournamentOptions& options,
                                    std::vector<std::string>* missing_figures = nullptr);

}  // namespace f16race::eval
