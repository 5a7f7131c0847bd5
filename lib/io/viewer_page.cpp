#include "io/viewer_page.hpp"

#include <algorithm>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <vector>

#include "io/atomic_file.hpp"
#include "io/viewer_assets.hpp"

namespace f16race::io {

namespace {

struct Part {
  std::string_view marker, content;
};

// The template with each part's marker replaced by its content. Markers are looked up in the
// template only, so a content that happens to hold one (a run named after it) changes nothing. The
// template is ours: a marker missing or doubled is a build mistake, not user input.
std::string fill(std::string_view page, const std::vector<Part>& parts) {
  std::vector<std::pair<std::size_t, const Part*>> at;
  for (const Part& p : parts) {
    const std::size_t pos = page.find(p.marker);
    if (pos == std::string_view::npos || page.find(p.marker, pos + 1) != std::string_view::npos)
      throw std::logic_error("apps/viewer/race_viewer.html: marker " + std::string(p.marker) + " must appear exactly once");
    at.emplace_back(pos, &p);
  }
  std::sort(at.begin(), at.end());
  std::string out;
  std::size_t from = 0;
  for (const auto& [pos, p] : at) {
    out.append(page.substr(from, pos - from)).append(p->content);
    from = pos + p->marker.size();
  }
  return out.append(page.substr(from));
}

// Inside a <script> element "</script" (any case) ends it, and the rest of the script would show as
// text: three.js and our script hold none today, and a new version that did is refused here.
void check_script(std::string_view what, std::string_view js) {
  std::string lower(js);
  for (char& c : lower) c = static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c);
  if (lower.find("</script") != std::string::npos)
    throw std::logic_error(std::string(what) + " contains </script and cannot be inlined in the replay page");
}

}  // namespace

std::string viewer_page_html(const std::string& race_json) {
  namespace a = viewer_assets;
  const std::string_view three(a::kThreeJs, a::kThreeJs_size), viewer(a::kViewerJs, a::kViewerJs_size);
  check_script("three.min.js", three);
  check_script("race_viewer.js", viewer);
  std::string json;
  json.reserve(race_json.size());
  for (const char c : race_json) {
    if (c == '<') json += "\\u003c";  // '<' is only ever inside a JSON string, where this escape means the same
    else json += c;
  }
  return fill(std::string_view(a::kPageTemplate, a::kPageTemplate_size),
              {{"/*F16RACE_RACE_JSON*/", json}, {"/*F16RACE_THREE_JS*/", three}, {"/*F16RACE_VIEWER_JS*/", viewer}});
}

void write_viewer_page(const std::string& path, const std::string& race_json) {
  write_file_atomic(path, viewer_page_html(race_json));
}

}  // namespace f16race::io
