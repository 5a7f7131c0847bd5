#include "eval/low_level_choice.hpp"

#include <utility>

#include "agents/expected_sarsa.hpp"
#include "eval/tournament.hpp"
#include "io/input_error.hpp"
#include "train/run_policy.hpp"

namespace f16race::eval {

std::uint64_t low_level_choice_tracks_seed(std::uint64_t seed) { return 0x5E1EC7ULL + seed; }

std::vector<double> center_vs_autopilot_winrates(const LowLevelChoiceInputs& in) {
  TournamentOptions o;
  o.include_untrained = false;
  o.include_autopilot = true;
  o.races_per_pair = in.races;
  o.seed = in.tracks_seed;
  std::vector<double> out;
  for (const std::string& file : in.ll_files) {
    std::vector<train::RunPolicy> pol;
    pol.push_back(train::untrained_policy(*in.config, 0));  // its high level is never asked
    try {
      pol.back().ll->load(file);
    } catch (const std::exception& e) {
      throw io::InputError(file + ": cannot load the low level (" + std::string(e.what()).substr(0, 160) +
                           "); the file is corrupt or truncated: restore it or resume from an earlier checkpoint");
    }
    pol.back().name = "candidate";
    const std::string variant = agents::es_variant_name(in.config->hl.variant);
    // The two entries of `tournament --controls --with-autopilot` that race here, in their order
    // there (the autopilot before the controls): the same sides on the same tracks.
    std::vector<Entry> entries{Entry{"autopilot", "", "autopilot", o.seed, HlOverride::none, -1},
                               Entry{"candidate@center", "", variant, in.config->seed, HlOverride::center, 0}};
    const TournamentResult r = race_entries(o, std::move(entries), pol);
    out.push_back(r.wins[1][0] / r.games[1][0]);
  }
  return out;
}

}  // namespace f16race::eval
