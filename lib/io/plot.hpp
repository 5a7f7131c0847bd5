#pragma once
// Figures through gnuplot. The caller writes the data (CSV); this module writes a gnuplot
// script next to it and runs gnuplot to make the PNG or SVG. The script stays on disk so a user
// can restyle the figure and re-run `gnuplot FILE.gp`. Without gnuplot the data and script are
// still written and render() says so.
#include <string>
#include <vector>

namespace f16race::io {

struct PlotSeries {
  std::string data_file;  // CSV with a header row (relative paths are relative to the script)
  std::string using_expr; // gnuplot `using` clause, e.g. "3:4" or "1:($2*2)"
  std::string style;      // e.g. "lines lw 1.5 lc rgb '#1f77b4'"
  std::string title;      // legend entry; empty = no legend entry
  std::string every;      // optional gnuplot `every` clause
};

struct PlotPanel {
  std::string title, xlabel, ylabel;
  std::vector<PlotSeries> series;  // empty: an empty [0:1]x[0:1] frame (say why with a label in `extra`)
  std::string extra;      // raw gnuplot commands for this panel (ranges, key position, ...)
};

struct PlotSpec {
  std::string output;     // .png or .svg
  int width_px = 1400;
  int height_px = 900;
  int rows = 1, cols = 1; // multiplot layout, panels fill row by row
  std::string title;
  std::vector<PlotPanel> panels;
  // Render to a temporary name in the output's folder, then rename over `output`, so a crash or a
  // failed gnuplot never leaves a half-written image (an older image stays intact). The script
  // still names `output`, so `gnuplot FILE.gp` by hand writes it directly.
  bool atomic_output = false;
};

// Writes `script_path` and runs gnuplot on it. Returns true when the image was made: gnuplot
// exited 0 and the image is whole (a PNG with its signature and IEND end, an SVG ending in
// </svg>). Otherwise false with `message` (one line) saying why (gnuplot missing or failed, the
// image empty or cut short), and no image under the output's name. Throws io::FileWriteError
// when the script cannot be written, or when the image failed on a disk with less free space than
// it could take (a full disk: the caller keeps its earlier output, as for any other file).
bool render_plot(const PlotSpec& spec, const std::string& script_path, std::string* message);

// Why the image at `path` is not a whole PNG (or, for *.svg, SVG), or "" when it is.
std::string image_problem(const std::string& path);

// True when a `gnuplot` executable is on the PATH.
bool gnuplot_available();

}  // namespace f16race::io
