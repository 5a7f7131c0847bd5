#pragma once
// The replay page's parts, embedded into the executable at build time (cmake/embed_text_files.cmake,
// from apps/viewer/): the HTML template, the page's script and three.js as npm installed it
// (apps/viewer/package-lock.json pins the version). Each is the file's bytes; NAME_size excludes
// the terminating NUL the literal adds.
#include <cstddef>

namespace f16race::io::viewer_assets {

extern const char kPageTemplate[];  // apps/viewer/race_viewer.html
extern const std::size_t kPageTemplate_size;
extern const char kViewerJs[];      // apps/viewer/race_viewer.js
extern const std::size_t kViewerJs_size;
extern const char kThreeJs[];       // apps/viewer/node_modules/three/build/three.min.js
extern const std::size_t kThreeJs_size;

}  // namespace f16race::io::viewer_assets
