#include "train/metrics_file.hpp"

#include <algorithm>
#include <cstdlib>
#include <vector>

#include "io/csv_table.hpp"
#include "io/input_error.hpp"

namespace f16race::train {

namespace {
const std::vector<std::string>& metrics_header() {
  static const std::vector<std::string> h = {
      "update", "phase_hl", "env_steps", "wall_s", "samples_per_s", "ll_return", "hl_return", "goal_dist_ft",
      "winrate", "finish_rate", "races", "term_collision", "term_altitude", "term_load", "term_turn_rate",
      "term_tube", "term_simulator", "policy_loss", "value_loss", "entropy", "approx_kl", "lr", "es_loss",
      "q_mean", "epsilon", "hl_grad_steps", "es_loss_heldout", "es_end_atom_share", "es_huber_share", "q_spread", "greedy_entropy",
      "off_center_share", "airspeed_ftps", "middle_share_x", "middle_share_y", "middle_share_z",
      "term_team_collision", "term_envelope"};
  return h;
}
}  // namespace

std::string metrics_header_line() {
  const auto& h = metrics_header();
  std::string line;
  for (std::size_t k = 0; k < h.size(); ++k) line += (k ? "," : "") + h[k];
  return line;
}
namespace {
std::vector<double> metrics_values(const MetricsRow& r) {
  return {static_cast<double>(r.update), r.phase == "hl" ? 1.0 : 0.0, static_cast<double>(r.env_steps), r.wall_s,
          r.samples_per_s, r.ll_return, r.hl_return, r.goal_dist_ft, r.winrate, r.finish_rate, r.races, r.term[1],
          r.term[2], r.term[3], r.term[4], r.term[5], r.term[6], r.policy_loss, r.value_loss, r.entropy, r.approx_kl,
          r.lr, r.es_loss, r.q_mean, r.epsilon, static_cast<double>(r.hl_grad_steps), r.es_loss_heldout, r.es_end_atom_share,
          r.es_huber_share, r.q_spread, r.greedy_entropy, r.off_center_share, r.airspeed_ftps,
          r.middle_share[0], r.middle_share[1], r.middle_share[2], r.term[race::kCauseTeamCollision],
          r.term[race::kCauseEnvelope]};
}
}  // namespace

std::string metrics_csv_line(const MetricsRow& row) {
  const auto v = metrics_values(row);
  std::string line;
  for (std::size_t k = 0; k < v.size(); ++k) line += (k ? "," : "") + (std::isnan(v[k]) ? "" : io::format_double(v[k]));
  return line + "\n";
}

namespace {
// The lines of `text` without their ends (LF, CRLF or CR), a leading byte-order mark dropped.
std::vector<std::string> text_lines(std::string text) {
  if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.erase(0, 3);
  std::vector<std::string> lines;
  std::string line;
  for (std::size_t k = 0; k < text.size(); ++k) {
    const char c = text[k];
    if (c != '\n' && c != '\r') {
      line += c;
      continue;
    }
    if (c == '\r' && k + 1 < text.size() && text[k + 1] == '\n') ++k;
    lines.push_back(line);
    line.clear();
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

// The update count a row starts with, or -1 when its first cell is not one.
std::int64_t row_update(const std::string& line) {
  const std::string cell = line.substr(0, line.find(','));
  if (cell.empty() || cell.size() > 18 || cell.find_first_not_of("0123456789") != std::string::npos) return -1;
  return std::strtoll(cell.c_str(), nullptr, 10);
}
}  // namespace

std::string metrics_kept_up_to(const std::string& text, std::int64_t updates, const std::string& path) {
  const std::string now = metrics_header_line();
  std::string out = now + "\n", pad;
  bool header = true;
  std::size_t number = 0;
  for (const std::string& line : text_lines(text)) {
    ++number;
    if (line.empty()) continue;
    const std::string where = path + ":" + std::to_string(number);
    if (header) {
      header = false;
      if (line == now) continue;
      // An older build's header is a prefix of today's: its rows get empty cells for the new columns.
      if (now.compare(0, line.size() + 1, line + ",") != 0)
        throw io::InputError(where + ": not the header of f16race's metrics.csv; move the file aside to resume (the "
                                     "run resumes from its checkpoint, with the rows after it only)");
      pad.assign(static_cast<std::size_t>(std::count(now.begin(), now.end(), ',') - std::count(line.begin(), line.end(), ',')), ',');
      continue;
    }
    const std::int64_t update = row_update(line);
    if (update < 0)
      throw io::InputError(where + ": '" + line.substr(0, std::min<std::size_t>(line.find(','), 40)) +
                           "' is not an update count, so this is not a metrics row; repair the line or move the file "
                           "aside to resume (the run resumes from its checkpoint, with the rows after it only)");
    if (update <= updates) out += line + pad + "\n";
  }
  return out;
}

}  // namespace f16race::train
