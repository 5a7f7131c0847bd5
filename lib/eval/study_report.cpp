#include "eval/study_report.hpp"

#include <omp.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

#include "eval/tournament_output.hpp"
#include "io/atomic_file.hpp"
#include "io/plot.hpp"
#include "io/provenance.hpp"
#include "io/staged_folder.hpp"

namespace f16race::eval {

namespace fs = std::filesystem;

namespace {

// One figure per interval: every run's winrate against its training opponents and its finish
// rate over env steps, a colour per variant.
void write_curves(const StudyConfig& cfg, const std::vector<StudyCell>& cells, double dt,
                  const std::string& out, std::string* note) {
  static const std::map<std::string, std::string> colour{
      {"es", "#7f7f7f"}, {"es_d1", "#1f77b4"}, {"es_d2", "#2ca02c"}, {"es_d3", "#d62728"}};
  io::PlotSpec spec;
  spec.output = (fs::path(out) / ("curves_" + interval_name(dt) + ".png")).string();
  spec.rows = 1;
  spec.cols = 2;
  spec.width_px = 1400;
  spec.height_px = 550;
  spec.atomic_output = true;
  spec.title = "Learning curves, HL interval " + interval_name(dt).substr(2) + " s (smoothed)";
  io::PlotPanel win{"winrate vs training opponents (self-play and pool)", "env steps", "winrate", {}, "set yrange [0:1]"};
  io::PlotPanel fin{"finish rate", "env steps", "races ended at the finish line", {}, "set yrange [0:1]"};
  for (const auto& c : cells) {
    if (interval_name(c.dt_hl_s) != interval_name(dt)) continue;
    const std::string data = fs::absolute(fs::path(c.run_dir) / "metrics.csv").string();
    const std::string style = "lines lw 1.2 lc rgb '" + colour.at(c.variant) + "'";
    const std::string title = c.seed == cfg.seeds.front() ? c.variant : "";
    win.series.push_back({data, "3:9 smooth bezier", style, title, ""});
    fin.series.push_back({data, "3:10 smooth bezier", style, title, ""});
  }
  spec.panels = {win, fin};
  std::string msg;
  if (!io::render_plot(spec, spec.output.substr(0, spec.output.size() - 4) + ".gp", &msg)) *note += msg + "\n";
}

}  // namespace

bool is_study_report_output(const std::string& name) {
  const auto ends_with = [&](const char* end) {
    const std::string e(end);
    return name.size() > e.size() && name.compare(name.size() - e.size(), e.size(), e) == 0;
  };
  return name == "report.md" || (name.rfind("curves_dt", 0) == 0 && (ends_with(".png") || ends_with(".gp")));
}

namespace {

// report.md's text; the learning curves of every interval raced so far are drawn into `dir`.
std::string report_text(const StudyConfig& cfg, const std::vector<StudyCell>& cells, const std::string& out,
                        const std::string& config_path, double tournament_s, const std::string& dir) {
  std::ostringstream md;
  md << "# Fig. 3 study: " << cfg.variants.size() << " variants x " << cfg.seeds.size() << " seeds x "
     << cfg.dt_hl_s.size() << " HL intervals\n\n";
  md << "Written by `f16race study --config " << config_path << " --out " << out << "`, a build of commit "
     << io::build_commit() << ", on " << io::cpu_model() << ", " << omp_get_num_procs() << " cores.\n\n";
  double train_s = 0.0;
  int n_finished = 0;
  for (const auto& c : cells) {
    const CellStatus s = cell_status(cfg, c);
    train_s += s.wall_s;
    n_finished += s.state == CellState::finished;
  }
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "Compute: %.1f h of training summed over %d of %zu runs finished (one thread each, %d at a time), "
                "%.0f s of tournaments in this pass.\n\n",
                train_s / 3600.0, n_finished, cells.size(), cfg.jobs, tournament_s);
  md << buf;
  md << "Each run: `f16race --threads 1 train --config " << cfg.base_config;
  for (const std::string& kv : cfg.set) md << " --set " << kv;
  md << " --set hl.agent=V --seed S --set race.dt_hl_s=D --set train.total_env_steps=" << cfg.total_env_steps
     << "`; each interval's tournament: `f16race tournament --runs <its runs>" << (cfg.controls ? " --controls" : "")
     << " --races " << cfg.races_per_pair << " --seed " << cfg.tournament_seed << "`.\n\n";
  std::string notes;
  for (double dt : cfg.dt_hl_s) {
    const std::string name = interval_name(dt);
    md << "## HL interval " << name.substr(2) << " s\n\n";
    const TournamentOptions t = interval_tournament(cfg, cells, dt, out);
    if (!tournament_complete(t)) {
      md << "Not raced yet: its runs are still training. Run the study command again to continue.\n\n";
      continue;
    }
    // The report sits in OUT/report/, beside the interval folders.
    md << "![tournament](../" << name << "/tournament/tournament.png)\n\n";
    write_curves(cfg, cells, dt, dir, &notes);
    md << "![learning curves](curves_" << name << ".png)\n\n";
    std::ifstream in(fs::path(t.out_dir) / "summary.md");
    std::string text((std::istreambuf_iterator<char>(in)), {});
    // The tournament's own title becomes a sub-heading here.
    if (text.rfind("# ", 0) == 0) text = "#" + text;
    md << text << "\n";
  }
  if (!notes.empty()) md << "Figures not drawn: " << notes << "\n";
  return md.str();
}

}  // namespace

void write_study_report(const StudyConfig& cfg, const std::vector<StudyCell>& cells, const std::string& out,
                        const std::string& config_path, double tournament_s) {
  io::StagedFolder folder((fs::path(out) / "report").string(), "study report", is_study_report_output);
  folder.commit([&](const std::string& dir) {
    io::write_file_atomic((fs::path(dir) / "report.md").string(),
                          report_text(cfg, cells, out, config_path, tournament_s, dir));
  });
  // The report of an earlier build sat in OUT itself: removed, so only one report is there.
  std::error_code ec;
  fs::remove(fs::path(out) / "report.md", ec);
  for (double dt : cfg.dt_hl_s)
    for (const char* ext : {".png", ".gp"}) fs::remove(fs::path(out) / ("curves_" + interval_name(dt) + ext), ec);
}

}  // namespace f16race::eval
