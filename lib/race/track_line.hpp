#pragma once
// The shortest line through a stretch of a track's tube: a taut string held inside every
// cross-section. What the best line could save over the center-line, at equal speed, is the
// ceiling on what a pilot gains by its line alone.
#include <vector>

#include "race/track.hpp"

namespace f16race::race {

struct TubeLineInputs {
  double s0_ft = 0.0;        // start of the stretch (arc length along the center-line)
  double s1_ft = 0.0;        // its end
  double inset_frac = 0.0;   // the line keeps (1 - inset_frac) x the local radius from the center
  double step_ft = 250.0;    // cross-sections this far apart along the center-line
  int max_sweeps = 200000;   // sweeps at most; it stops once no point moves tolerance_ft in a sweep
  double tolerance_ft = 1e-5;
};

struct TubeLine {
  double center_ft = 0.0;    // length of the center-line polyline through the same cross-sections
  double shortest_ft = 0.0;  // length of the taut line
  int sweeps = 0;            // relaxation sweeps it took
  // The line itself: its offsets from the center-line along the section's right and up axes,
  // at cross-sections evenly spaced from s0_ft to s1_ft.
  double s0_ft = 0.0, s1_ft = 0.0;
  std::vector<double> right_ft, up_ft;  // [n_sections]

  struct Offset {
    double right_ft = 0.0, up_ft = 0.0;
  };
  // Linear between sections; before s0 and after s1 the end sections' offsets.
  Offset offset_at(double s_ft) const;
};

TubeLine shortest_tube_line(const Track& track, const TubeLineInputs& in);

}  // namespace f16race::race
