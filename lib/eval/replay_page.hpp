#pragma once
// A replayed race as the 3-D page of `f16race replay --html` (io/viewer_page.hpp): the race as
// compact JSON, written into the page with three.js and the viewer's script. Needs no LibTorch.
#include <string>

#include "eval/replay.hpp"

namespace f16race::eval {

// Samples no closer than this in the page: the LL step (0.08 s by default) is kept, finer steps are
// thinned to at most 20 Hz, which the page interpolates smoothly.
inline constexpr double kPageMinSampleS = 0.05;

// The race as the page reads it (apps/viewer/race_viewer.js; fields in docs/viewer.md): every
// stride-th recorded step (stride = the fewest LL steps spanning kPageMinSampleS), positions in
// whole feet relative to the track's center (altitude as is), angles in centiradians, airspeed in
// whole ft/s, progress in whole feet; each aircraft's fate, HL goals and the blocks. ~40 bytes per
// aircraft and sample: a 60 s race of 8 aircraft at 12.5 Hz is ~250 KB, three.js another 600 KB.
std::string replay_page_json(const RaceReplay& replay);

// The page (io::write_viewer_page: atomic) at `path`.
void write_replay_page(const RaceReplay& replay, const std::string& path);

}  // namespace f16race::eval
