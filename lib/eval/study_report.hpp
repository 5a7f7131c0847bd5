#pragma once
// A study's report: OUT/report.md with every HL interval whose tournament is written (its Fig. 3
// panels, its learning curves, its tournament summary), the compute spent, the build's commit,
// the machine and the exact commands; and OUT/curves_dtN.png, every run's winrate and finish
// rate over env steps, a colour per variant. An interval still training is named as such, so a
// study stopped half way already publishes its finished horizon.
#include <string>
#include <vector>

#include "eval/study.hpp"

namespace f16race::eval {

// `config_path` is the study config as the user named it (quoted in the commands);
// `tournament_s` the tournament time of this pass. Written atomically; a figure gnuplot cannot
// draw is named in the report instead.
void write_study_report(const StudyConfig& config, const std::vector<StudyCell>& cells, const std::string& out_dir,
                        const std::string& config_path, double tournament_s);

}  // namespace f16race::eval
