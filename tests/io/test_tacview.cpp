// Tacview ACMI writer: header Tacview requires, objects introduced once with their properties,
// frames in time order, removals, hex ids and the flat-earth conversion.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "io/tacview.hpp"

namespace f16race::io {
namespace {

std::vector<std::string> lines_of(const std::string& path) {
  std::ifstream f(path);
  std::vector<std::string> out;
  for (std::string l; std::getline(f, l);) out.push_back(l);
  return out;
}

TEST(Tacview, ConvertsLocalFeetToDegrees) {
  // One nautical mile (6076.12 ft) north is one arc-minute of latitude to 0.1 %.
  EXPECT_NEAR(north_ft_to_lat_deg(6076.12) * 60.0, 1.0, 1e-3);
  // East offsets stretch by 1 / cos(latitude).
  EXPECT_NEAR(east_ft_to_lon_deg(6076.12, 60.0) * 60.0, 2.0, 2e-3);
  EXPECT_DOUBLE_EQ(east_ft_to_lon_deg(0.0, 45.0), 0.0);
}

TEST(Tacview, WritesFramesInOrderWithObjectsIntroducedOnce) {
  AcmiScene scene;
  scene.title = "test race";
  AcmiObject a;
  a.id = 0x10A;
  a.type = "Air+FixedWing";
  a.name = "F-16C";
  a.pilot = "blue 0";
  a.color = "Blue";
  a.coalition = "Blue team";
  a.samples = {{0.0, 0.0, 0.0, 1000.0, 0.0, 0.0, M_PI / 2}, {0.5, 100.0, 0.0, 1000.0, 0.1, 0.0, M_PI / 2}};
  a.removed_at_s = 0.75;
  a.destroyed = true;
  AcmiObject b;
  b.id = 0x20;
  b.type = "Navaid+Static+Waypoint";
  b.attitude = false;
  b.samples = {{0.25, 0.0, 3280.84, 0.0}};
  scene.objects = {a, b};
  const std::string path = (std::filesystem::temp_directory_path() / "f16race_test.acmi").string();
  write_acmi(path, scene);
  const auto L = lines_of(path);
  ASSERT_GE(L.size(), 12u);
  EXPECT_EQ(L[0], "\xEF\xBB\xBF" "FileType=text/acmi/tacview");
  EXPECT_EQ(L[1], "FileVersion=2.2");
  EXPECT_NE(std::find(L.begin(), L.end(), "0,Title=test race"), L.end());
  std::vector<double> frames;
  int intro = 0, removed = 0, destroyed = 0;
  for (const std::string& l : L) {
    if (l[0] == '#') frames.push_back(std::stod(l.substr(1)));
    if (l.rfind("10a,T=", 0) == 0 && l.find("Type=Air+FixedWing") != std::string::npos) {
      ++intro;
      EXPECT_NE(l.find("Name=F-16C,Pilot=blue 0,Color=Blue,Coalition=Blue team"), std::string::npos) << l;
      // Altitude in metres, yaw in degrees.
      EXPECT_NE(l.find("|304.80|0.00|0.00|90.00"), std::string::npos) << l;
    }
    removed += l == "-10a";
    destroyed += l == "0,Event=Destroyed|10a|";
    if (l.rfind("20,T=", 0) == 0) {
      // 1 km east at the reference latitude, no attitude fields.
      const double lon = std::stod(l.substr(5));
      EXPECT_NEAR(lon, east_ft_to_lon_deg(3280.84, scene.reference_latitude_deg), 1e-7);
      EXPECT_EQ(std::count(l.begin(), l.end(), '|'), 2) << l;
    }
  }
  EXPECT_EQ(intro, 1);
  EXPECT_EQ(removed, 1);
  EXPECT_EQ(destroyed, 1);
  EXPECT_EQ(frames, (std::vector<double>{0.0, 0.25, 0.5, 0.75}));
  // A second sample of the same object carries no properties again.
  int later = 0;
  for (const std::string& l : L) later += l.rfind("10a,T=", 0) == 0 && l.find("Type=") == std::string::npos;
  EXPECT_EQ(later, 1);
}

TEST(Tacview, RefusesZeroIdsAndUnwritablePaths) {
  AcmiScene scene;
  scene.objects.push_back(AcmiObject{});
  EXPECT_THROW(write_acmi("/tmp/f16race_zero_id.acmi", scene), std::runtime_error);
  scene.objects.clear();
  // A folder that cannot be created (its parent is a device, not a folder).
  EXPECT_THROW(write_acmi("/dev/null/dir/x.acmi", scene), std::runtime_error);
}

}  // namespace
}  // namespace f16race::io
