#include "io/plot.hpp"

#include "io/atomic_file.hpp"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include <sys/statvfs.h>
#include <unistd.h>

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
// One word for /bin/sh, whatever the text holds.
std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char ch : s) out += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
  return out + "'";
}
// gnuplot -e variable that redirects an atomic_output script to its temporary name.
constexpr const char* kOutputVar = "f16race_output";

// gnuplot's messages on one line, cut to a readable length: a failed figure is one line.
std::string one_line(const std::string& text) {
  std::string out;
  for (char ch : text) {
    if (ch == '\n' || ch == '\r' || ch == '\t') ch = ' ';
    if (ch == ' ' && (out.empty() || out.back() == ' ')) continue;
    out += ch;
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  return out.size() > 300 ? out.substr(0, 297) + "..." : out;
}
}  // namespace

std::string image_problem(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return "no image was written";
  std::fseek(f, 0, SEEK_END);
  const long size = std::ftell(f);
  const bool svg = path.size() > 4 && path.compare(path.size() - 4, 4, ".svg") == 0;
  std::string head(8, '\0'), tail(svg ? 256 : 12, '\0');
  std::size_t got_head = 0, got_tail = 0;
  if (size > 0) {
    std::fseek(f, 0, SEEK_SET);
    got_head = std::fread(head.data(), 1, head.size(), f);
    const long from = std::max(0L, size - static_cast<long>(tail.size()));
    std::fseek(f, from, SEEK_SET);
    got_tail = std::fread(tail.data(), 1, tail.size(), f);
    tail.resize(got_tail);
  }
  std::fclose(f);
  if (size <= 0) return "the image is empty";
  if (svg) return tail.find("</svg>") != std::string::npos ? "" : "the SVG ends before </svg> (cut short)";
  // A PNG starts with its 8-byte signature and ends with the IEND chunk: a cut file lacks the end.
  static const std::string signature("\x89PNG\r\n\x1a\n", 8);
  static const std::string iend("\0\0\0\0IEND\xae\x42\x60\x82", 12);
  if (got_head != 8 || head != signature) return "the file is not a PNG";
  if (tail != iend) return "the PNG ends before its IEND chunk (cut short)";
  return "";
}

bool gnuplot_available() { return std::system("command -v gnuplot >/dev/null 2>&1") == 0; }

namespace {

// The gnuplot script that draws `spec` (run from the script's folder).
std::string gnuplot_script(const PlotSpec& spec, const std::string& script_path) {
  std::ostringstream gp;
  const bool svg = spec.output.size() > 4 && spec.output.substr(spec.output.size() - 4) == ".svg";
  gp << "# Written by f16race; run `gnuplot " << base_of(script_path) << "` in this folder to redraw.\n";
  gp << "set terminal " << (svg ? "svg" : "pngcairo") << " size " << spec.width_px << "," << spec.height_px
     << " font 'Sans,10'\n";
  if (spec.atomic_output) {
    // render_plot passes a temporary name through -e and renames it afterwards; run by hand,
    // the script writes the image directly.
    gp << "if (!exists(\"" << kOutputVar << "\")) " << kOutputVar << " = " << quote(base_of(spec.output)) << "\n";
    gp << "set output " << kOutputVar << "\n";
  } else {
    gp << "set output " << quote(base_of(spec.output)) << "\n";
  }
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
    if (p.series.empty()) gp << "plot [0:1] [0:1] -1 notitle";  // an empty frame, no error
    else gp << "plot ";
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
  return gp.str();
}

// gnuplot exits 0 with a PNG cut short when the disk fills under it, so a bad image on a disk with
// less room than the image could take (uncompressed RGBA bounds a PNG) is a full disk: an error, as
// for every other file, so that the caller keeps the earlier output whole instead of a figureless one.
void throw_if_disk_full(const std::string& dir, const PlotSpec& spec, const std::string& why) {
  struct statvfs fs {};
  if (::statvfs(dir.c_str(), &fs) != 0) return;
  const double free_bytes = static_cast<double>(fs.f_bavail) * static_cast<double>(fs.f_frsize);
  const double image_bound = 4.0 * spec.width_px * spec.height_px + 65536.0;
  if (free_bytes >= image_bound) return;
  throw FileWriteError(dir + "/" + base_of(spec.output) + ": no space left on device (" +
                       std::to_string(static_cast<long long>(free_bytes / 1024)) + " KB free; " + why +
                       "); nothing earlier was replaced: free some space and run the command again");
}

}  // namespace

bool render_plot(const PlotSpec& spec, const std::string& script_path, std::string* message) {
  write_file_atomic(script_path, gnuplot_script(spec, script_path));
  if (!gnuplot_available()) {
    if (message) *message = "gnuplot not found (install gnuplot-nox); data and " + script_path + " were written";
    return false;
  }
  const std::string dir = dir_of(script_path);
  std::string tmp_base;  // atomic_output: the image gnuplot writes, renamed to the output on success
  if (spec.atomic_output) {
    static std::atomic<unsigned> counter{0};
    tmp_base = "." + base_of(spec.output) + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
  }
  const std::string cmd = "cd " + shell_quote(dir) + " && gnuplot " +
                          (tmp_base.empty() ? std::string() : "-e " + shell_quote(std::string(kOutputVar) + "=" + quote(tmp_base)) + " ") +
                          shell_quote(base_of(script_path)) + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  std::string out;
  if (pipe) {
    char buf[256];
    while (std::fgets(buf, sizeof buf, pipe)) out += buf;
  }
  const int rc = pipe ? pclose(pipe) : -1;
  // The image gnuplot wrote: checked before it takes the output's name, and removed when bad,
  // so a failed figure never sits under its final name half written.
  const std::string image = dir + "/" + (tmp_base.empty() ? base_of(spec.output) : tmp_base);
  const std::string problem = rc == 0 ? image_problem(image) : std::string();
  if (rc != 0 || !problem.empty()) {
    std::remove(image.c_str());
    throw_if_disk_full(dir, spec, rc != 0 ? "gnuplot failed: " + one_line(out) : problem);
    if (message)
      *message = rc != 0 ? "gnuplot failed on " + script_path + ": " + one_line(out)
                         : "gnuplot ran on " + script_path + " but " + problem + " (" + base_of(spec.output) + ")";
    return false;
  }
  if (!tmp_base.empty()) {
    // Same folder, so rename() replaces the old image in one step.
    const std::string final_path = dir + "/" + base_of(spec.output);
    if (std::rename(image.c_str(), final_path.c_str()) != 0) {
      std::remove(image.c_str());
      if (message) *message = "gnuplot ran on " + script_path + " but " + image + " could not be renamed to " + final_path;
      return false;
    }
  }
  if (message) *message = spec.output;
  return true;
}

}  // namespace f16race::io
