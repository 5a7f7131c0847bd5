#include "io/tacview.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

#include "io/atomic_file.hpp"

namespace f16race::io {

namespace {

constexpr double kFtToM = 0.3048;
constexpr double kEarthRadiusM = 6371008.8;  // mean radius (IUGG)
constexpr double kRadToDeg = 180.0 / M_PI;

struct Event {
  double t;
  std::size_t object;
  int kind;  // 0 sample, 1 removal
  std::size_t sample;
};

}  // namespace

double north_ft_to_lat_deg(double north_ft) { return north_ft * kFtToM / kEarthRadiusM * kRadToDeg; }

double east_ft_to_lon_deg(double east_ft, double reference_latitude_deg) {
  return east_ft * kFtToM / (kEarthRadiusM * std::cos(reference_latitude_deg / kRadToDeg)) * kRadToDeg;
}

void write_acmi(const std::string& path, const AcmiScene& scene) {
  std::vector<Event> events;
  for (std::size_t o = 0; o < scene.objects.size(); ++o) {
    const AcmiObject& obj = scene.objects[o];
    if (obj.id == 0) throw std::runtime_error(path + ": ACMI object ids must be nonzero");
    for (std::size_t k = 0; k < obj.samples.size(); ++k) events.push_back({obj.samples[k].t_s, o, 0, k});
    if (obj.removed_at_s >= 0.0) events.push_back({obj.removed_at_s, o, 1, 0});
  }
  // Frames in time order; within a frame objects keep their order, removals last.
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) {
    return a.t != b.t ? a.t < b.t : a.kind < b.kind;
  });
  std::ostringstream f;
  // Tacview requires the UTF-8 byte order mark on text ACMI files.
  f << "\xEF\xBB\xBF" << "FileType=text/acmi/tacview\nFileVersion=2.2\n";
  char buf[512];
  std::snprintf(buf, sizeof buf, "0,ReferenceTime=%s\n0,ReferenceLongitude=%.6f\n0,ReferenceLatitude=%.6f\n",
                scene.reference_time.c_str(), scene.reference_longitude_deg, scene.reference_latitude_deg);
  f << buf;
  f << "0,DataSource=f16race\n0,Author=" << scene.author << "\n";
  if (!scene.title.empty()) f << "0,Title=" << scene.title << "\n";
  std::vector<bool> introduced(scene.objects.size(), false);
  double frame_t = -1.0;
  for (const Event& ev : events) {
    if (ev.t != frame_t) {
      std::snprintf(buf, sizeof buf, "#%.2f\n", ev.t);
      f << buf;
      frame_t = ev.t;
    }
    const AcmiObject& obj = scene.objects[ev.object];
    if (ev.kind == 1) {
      if (obj.destroyed) {
        std::snprintf(buf, sizeof buf, "0,Event=Destroyed|%llx|\n", static_cast<unsigned long long>(obj.id));
        f << buf;
      }
      std::snprintf(buf, sizeof buf, "-%llx\n", static_cast<unsigned long long>(obj.id));
      f << buf;
      continue;
    }
    const AcmiSample& s = obj.samples[ev.sample];
    const double lon = east_ft_to_lon_deg(s.east_ft, scene.reference_latitude_deg);
    const double lat = north_ft_to_lat_deg(s.north_ft);
    const double alt_m = s.alt_ft * kFtToM;
    if (obj.attitude)
      std::snprintf(buf, sizeof buf, "%llx,T=%.7f|%.7f|%.2f|%.2f|%.2f|%.2f", static_cast<unsigned long long>(obj.id), lon,
                    lat, alt_m, s.roll_rad * kRadToDeg, s.pitch_rad * kRadToDeg, s.yaw_rad * kRadToDeg);
    else
      std::snprintf(buf, sizeof buf, "%llx,T=%.7f|%.7f|%.2f", static_cast<unsigned long long>(obj.id), lon, lat, alt_m);
    f << buf;
    if (!introduced[ev.object]) {
      introduced[ev.object] = true;
      f << ",Type=" << obj.type;
      if (!obj.name.empty()) f << ",Name=" << obj.name;
      if (!obj.pilot.empty()) f << ",Pilot=" << obj.pilot;
      if (!obj.color.empty()) f << ",Color=" << obj.color;
      if (!obj.coalition.empty()) f << ",Coalition=" << obj.coalition;
    }
    f << "\n";
  }
  write_file_atomic(path, f.str());
}

}  // namespace f16race::io
