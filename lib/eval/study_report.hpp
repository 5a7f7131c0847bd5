#pragma once
// A study's report, OUT/report/: report.md with every HL interval whose tournament is complete
// (its Fig. 3 panels, its learning curves, its tournament summary), the compute spent, the
// build's commit, the machine and the exact commands; and curves_dtN.png, every run's winrate and
// finish rate over env steps, a colour per variant. An interval still training is named as such,
// so a study stopped half way already publishes its finished horizon. The folder is written
// whole (io::StagedFolder): report.md never names figures of another version.
#include <string>
#include <vector>

#include "eval/study.hpp"

namespace f16race::eval {

// `config_path` is the study config as the user named it (quoted in the commands);
// `tournament_s` the tournament time of this pass. A figure gnuplot cannot draw is named in the
// report instead. The report of earlier builds, OUT/report.md and OUT/curves_dtN.*, is removed.
void write_study_report(const StudyConfig& config, const std::vector<StudyCell>& cells, const std::string& out_dir,
                        const std::string& config_path, double tournament_s);

// Whether `name` is one of the report folder's files (report.md, curves_dt*.png, curves_dt*.gp).
bool is_study_report_output(const std::string& name);

}  // namespace f16race::eval
