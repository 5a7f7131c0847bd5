#include "eval/tournament_output.hpp"

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>

#include "io/atomic_file.hpp"
#include "io/byte_hash.hpp"

namespace f16race::eval {

namespace fs = std::filesystem;

namespace {

constexpr const char* kMarkerHeader = "f16race tournament output, written last: the folder is whole";
constexpr const char* kDrawn = "figures: drawn";

// "runs/a/es_s1+runs/b/es_s1@center" -> "es_s1+es_s1@center".
std::string run_names(const std::string& spec) {
  std::string out, part;
  std::istringstream in(spec);
  while (std::getline(in, part, '+')) {
    fs::path p = fs::path(part).lexically_normal();
    if (!p.has_filename()) p = p.parent_path();
    out += (out.empty() ? "" : "+") + p.filename().string();
  }
  return out;
}

const char* yes_no(bool b) { return b ? "yes" : "no"; }

// The tracks file as the races saw it: its name and a hash of its bytes (an edit races anew).
std::string tracks_identity(const std::string& path) {
  if (path.empty()) return "runs'";
  std::ostringstream s;
  s << fs::path(path).filename().string() << ":";
  std::ifstream in(path, std::ios::binary);
  if (!in) return s.str() + "unreadable";
  const std::string bytes((std::istreambuf_iterator<char>(in)), {});
  s << std::hex << io::fnv1a(bytes);
  return s.str();
}

}  // namespace

bool is_tournament_output(const std::string& name) {
  static const std::set<std::string> names{
      "races.csv", "pairings.csv", "summary.json", "summary.md",    "variants.csv", "variant_matrix.csv",
      "heatmap.csv", "tournament.gp", "tournament.png", "pairings.gp", "pairings.png", kTournamentMarker};
  return names.count(name) > 0;
}

std::string tournament_marker_options(const TournamentOptions& o) {
  std::ostringstream s;
  s << "races=" << o.races_per_pair << " seed=" << o.seed << " epsilon=" << o.epsilon << " batch=" << o.batch_envs
    << " bootstrap=" << o.bootstrap_replicates << " untrained=" << yes_no(o.include_untrained)
    << " untrained_in_statistics=" << yes_no(o.untrained_in_statistics) << " autopilot=" << yes_no(o.include_autopilot)
    << " controls=" << yes_no(o.controls) << " axis_controls=" << yes_no(o.axis_controls)
    << " autopilot_airspeed=" << o.autopilot_airspeed_ftps << " tracks=" << tracks_identity(o.tracks_config);
  if (o.goal_line_frac >= 0.0) s << " goal_line=" << o.goal_line_frac;  // absent: older markers read the same
  if (!std::isnan(o.goal_shift_up_frac)) s << " goal_shift_up=" << o.goal_shift_up_frac;
  if (o.autopilot_on_line) s << " autopilot_on_line=yes";
  if (!std::isnan(o.autopilot_shift_up_frac)) s << " autopilot_shift_up=" << o.autopilot_shift_up_frac;
  if (o.controls_own_run) s << " controls_own_run=yes";
  s << " runs=";
  for (std::size_t k = 0; k < o.runs.size(); ++k) s << (k ? "," : "") << run_names(o.runs[k]);
  return s.str();
}

void write_tournament_marker(const TournamentOptions& o, const std::vector<std::string>& missing,
                             const std::string& dir) {
  std::string text = std::string(kMarkerHeader) + "\noptions: " + tournament_marker_options(o) + "\n";
  if (missing.empty()) {
    text += std::string(kDrawn) + "\n";
  } else {
    text += "figures: missing";
    for (std::size_t k = 0; k < missing.size(); ++k) text += (k ? "; " : " ") + missing[k];
    text += "\n";
  }
  io::write_file_atomic((fs::path(dir) / kTournamentMarker).string(), text);
}

bool tournament_complete(const TournamentOptions& o, std::string* why) {
  const fs::path path = fs::path(o.out_dir) / kTournamentMarker;
  std::ifstream in(path);
  std::string header, options, figures;
  std::getline(in, header);
  std::getline(in, options);
  std::getline(in, figures);
  std::string reason;
  if (!in && header.empty()) reason = path.string() + " is missing: the tournament was not finished";
  else if (header != kMarkerHeader) reason = path.string() + " is not a tournament's marker";
  else if (options != "options: " + tournament_marker_options(o)) reason = "it was raced with other options";
  else if (figures != kDrawn) reason = figures;
  if (why) *why = reason;
  return reason.empty();
}

}  // namespace f16race::eval
