#pragma once
// The self-contained 3-D replay page (`f16race replay --html`): one HTML file holding three.js, the
// viewer's script and the race as JSON, so it opens from disk with no network. What the page draws
// and how it reads the JSON: docs/viewer.md and apps/viewer/race_viewer.js.
#include <string>

namespace f16race::io {

// The page for `race_json` (a JSON object, as eval/replay_page.hpp writes it). '<' in the JSON is
// written as \u003c, so no string in it can close the <script> element that holds it.
std::string viewer_page_html(const std::string& race_json);

// viewer_page_html(race_json) written to `path` atomically (io/atomic_file.hpp); throws
// io::FileWriteError naming the file when it cannot be written.
void write_viewer_page(const std::string& path, const std::string& race_json);

}  // namespace f16race::io
