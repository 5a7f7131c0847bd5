#pragma once
// Tacview ACMI 2.2 text files (https://www.tacview.net/documentation/acmi/): objects with
// positions in a local north/east/up frame, converted to longitude/latitude offsets around a
// reference point (flat-earth, fine over a race's tens of miles), attitudes in degrees, and
// team colours and coalitions. Written to a temporary file and renamed, like every output.
#include <cstdint>
#include <string>
#include <vector>

namespace f16race::io {

struct AcmiSample {
  double t_s = 0.0;
  double north_ft = 0.0, east_ft = 0.0, alt_ft = 0.0;
  double roll_rad = 0.0, pitch_rad = 0.0, yaw_rad = 0.0;  // used when the object has attitude
};

struct AcmiObject {
  std::uint64_t id = 0;     // unique, nonzero (written in hex as ACMI wants)
  std::string type;         // e.g. "Air+FixedWing", "Navaid+Static+Waypoint"
  std::string name;         // e.g. "F-16C"
  std::string pilot;        // label shown next to the object
  std::string color;        // Red, Blue, Green, Orange, Yellow, Cyan, Grey, ...
  std::string coalition;    // e.g. "Blue team"
  bool attitude = true;     // write roll|pitch|yaw as well as the position
  std::vector<AcmiSample> samples;  // increasing t_s
  double removed_at_s = -1.0;       // >= 0: the object leaves the scene then
  bool destroyed = false;           // with removed_at_s: also log a Destroyed event
};

struct AcmiScene {
  double reference_latitude_deg = 36.2;     // around Nellis AFB by default
  double reference_longitude_deg = -115.0;
  std::string reference_time = "2026-01-01T12:00:00Z";
  std::string title;
  std::string author = "f16race";
  std::vector<AcmiObject> objects;
};

// Throws std::runtime_error naming the file if it cannot be written.
void write_acmi(const std::string& path, const AcmiScene& scene);

// Local offsets [ft] to degrees of latitude / longitude at the reference latitude.
double north_ft_to_lat_deg(double north_ft);
double east_ft_to_lon_deg(double east_ft, double reference_latitude_deg);

}  // namespace f16race::io
