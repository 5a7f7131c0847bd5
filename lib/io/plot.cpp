#include "io/plot.hpp"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>

namespace f16race::io {

namespace {
std::string quote(const std::string& s) {
  std::string out = "'";
  for (char ch : s) out += ch == '\'' ? std::string("''") : std::string(1, ch);
  return out + "'";
}
std::string dir_of(const std::string& path) {
  const auto p = path.find_last_of('/');
  return p == std::string::npos ? "." : path.substr(0, p);
}
std::string base_of(const std::string& path) {
  const auto p = path.find_last_of('/');
  return p == std::string::npos ? path : path.substr(p + 1);
}
}  // namespace

bool gnuplot_available() { return std::system("command -v gnuplot >/dev/null 2>&1") == 0; }

bool render_plot(const PlotSpec& spec, const std::string& script_path, std::string* message) {
  {
    std::ofstream gp(script_path);
    if (!gp) throw std::runtime_error(script_path + ": cannot write the gnuplot script");
    const bool svg = spec.output.size() > 4 && spec.output.substr(spec.output.size() - 4) == ".svg";
    gp << "# Written by f16race; run `gnuplot " << base_of(script_path) << "` in this folder to redraw.\n";
    gp << "set terminal " << (svg ? "svg" : "pngcairo") << " size " << spec.width_px << "," << spec.height_px
       << " font 'Sans,10'\n";
    gp << "set output " << quote(base_of(spec.output)) << "\n";
    gp << "set datafile separator ','\n";
    gp << "set termoption noenhanced\n";  // names like es_d3 are text, not subscripts
    gp << "set grid lc rgb '#dddddd'\n";
    gp << "set key outside right top\n";
    gp << "set multiplot layout " << spec.rows << "," << spec.cols;
    if (!spec.title.empty()) gp << " title " << quote(spec.title);
    gp << "\n";
    for (const PlotPanel& p : spec.panels) {
      gp << "set title " << quote(p.title) << "\nset xlabel " << quote(p.xlabel) << "\nset ylabel " << quote(p.ylabel)
         << "\n";
      if (!p.extra.empty()) gp << p.extra << "\n";
      gp << "plot ";
      for (std::size_t k = 0; k < p.series.size(); ++k) {
        const PlotSeries& s = p.series[k];
        gp << (k ? ", \\\n     " : "") << quote(s.data_file) << " every " << (s.every.empty() ? "::1" : s.every)
           << " using " << s.using_expr << " with " << s.style << " "
           << (s.title.empty() ? std::string("notitle") : "title " + quote(s.title));
      }
      gp << "\n";
      if (!p.extra.empty()) gp << "unset arrow; unset label; unset object; set autoscale\n";
    }
    gp << "unset multiplot\n";
  }
  if (!gnuplot_available()) {
    if (message) *message = "gnuplot not found (install gnuplot-nox); data and " + script_path + " were written";
    return false;
  }
  const std::string cmd = "cd " + quote(dir_of(script_path)) + " && gnuplot " + quote(base_of(script_path)) + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  std::string out;
  if (pipe) {
    char buf[256];
    while (std::fgets(buf, sizeof buf, pipe)) out += buf;
  }
  const int rc = pipe ? pclose(pipe) : -1;
  if (rc != 0) {
    if (message) *message = "gnuplot failed on " + script_path + ": " + out;
    return false;
  }
  if (message) *message = spec.output;
  return true;
}

}  // namespace f16race::io
