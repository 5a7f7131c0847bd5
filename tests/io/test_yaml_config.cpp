// Config validation: every bad input is one line naming the file, the key path and the fix.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "io/yaml_config.hpp"

namespace f16race::io {
namespace {

struct Cfg {
  double dt = 0.08;
  int n = 64;
  bool flag = false;
  std::string mode = "grace";
  std::vector<int> hidden{64, 64};
  int inner = 3;
};

Cfg read(const std::string& text) {
  Cfg c;
  ConfigReader r(YAML::Load(text), "cfg.yaml");
  r.read("dt", &c.dt, 0.001, 1.0);
  r.read("n", &c.n, 1, 1024);
  r.read("flag", &c.flag);
  r.read("mode", &c.mode, {"grace", "terminate"});
  r.read("hidden", &c.hidden, 1, 4096);
  ConfigReader sub = r.child("sub");
  sub.read("inner", &c.inner, 0, 10);
  sub.finish();
  r.finish();
  return c;
}

std::string error_of(const std::string& text) {
  try {
    read(text);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(YamlConfig, MissingKeysKeepDefaultsAndPresentOnesAreRead) {
  const Cfg c = read("n: 8\nsub: {inner: 5}\nhidden: [32, 16]\n");
  EXPECT_EQ(c.n, 8);
  EXPECT_EQ(c.inner, 5);
  EXPECT_EQ(c.dt, 0.08);
  EXPECT_EQ(c.hidden, (std::vector<int>{32, 16}));
}

TEST(YamlConfig, UnknownKeyNamesItsPath) {
  const std::string e = error_of("sub: {inner: 1, innr: 2}\n");
  EXPECT_NE(e.find("cfg.yaml: unknown key 'sub.innr'"), std::string::npos) << e;
  EXPECT_NE(e.find("inner"), std::string::npos) << e;  // lists what is known
}

TEST(YamlConfig, RepeatedKeyIsRefusedWithItsLineInsteadOfFirstWins) {
  std::string e = error_of("n: 6\ndt: 0.1\nn: 4\n");
  EXPECT_NE(e.find("cfg.yaml:3: n is given twice; keep one of them"), std::string::npos) << e;
  e = error_of("sub:\n  inner: 1\n  inner: 2\n");
  EXPECT_NE(e.find("cfg.yaml:3: sub.inner is given twice"), std::string::npos) << e;
  EXPECT_EQ(error_of("n: 6\nsub: {inner: 2}\n"), "");
}

TEST(YamlConfig, WrongTypeAndOutOfRangeNameKeyValueAndRange) {
  std::string e = error_of("n: lots\n");
  EXPECT_NE(e.find("cfg.yaml: n: expected an integer, got 'lots'"), std::string::npos) << e;
  e = error_of("n: 5000\n");
  EXPECT_NE(e.find("n: value 5000 is out of range; allowed [1, 1024]"), std::string::npos) << e;
  e = error_of("dt: [1]\n");
  EXPECT_NE(e.find("dt: expected a number, got a list"), std::string::npos) << e;
  e = error_of("mode: sometimes\n");
  EXPECT_NE(e.find("'sometimes' is not one of: grace, terminate"), std::string::npos) << e;
  e = error_of("flag: maybe\n");
  EXPECT_NE(e.find("flag: expected true or false"), std::string::npos) << e;
  e = error_of("sub: 3\n");
  EXPECT_NE(e.find("'sub' must be a mapping"), std::string::npos) << e;
}

// nan, infinities, huge and fractional numbers, and an empty value (`key:` or --set key=) are
// refused naming the key and the value; an empty value is not "a mapping".
TEST(YamlConfig, NonFiniteHugeFractionalAndEmptyValuesNameKeyAndValue) {
  for (const char* v : {".nan", ".inf", "-.inf", "1e308"}) {
    const std::string e = error_of(std::string("dt: ") + v + "\n");
    EXPECT_NE(e.find("cfg.yaml: dt: "), std::string::npos) << e;
    EXPECT_NE(e.find("allowed [0.001, 1]"), std::string::npos) << e;
  }
  for (const char* v : {"nan", "inf", "1.5", "1e308", "99999999999999999999"}) {
    const std::string e = error_of(std::string("n: ") + v + "\n");
    EXPECT_NE(e.find(std::string("cfg.yaml: n: expected an integer, got '") + v + "'"), std::string::npos) << e;
  }
  std::string e = error_of("n:\n");
  EXPECT_NE(e.find("cfg.yaml: n: expected an integer, got an empty value"), std::string::npos) << e;
  e = error_of("dt:\n");
  EXPECT_NE(e.find("dt: expected a number, got an empty value"), std::string::npos) << e;
  e = error_of("mode:\n");
  EXPECT_NE(e.find("mode: expected a string, got an empty value"), std::string::npos) << e;
  e = error_of("hidden:\n");
  EXPECT_NE(e.find("hidden: expected a list of integers like [64, 64], got an empty value"), std::string::npos) << e;
  YAML::Node root = YAML::Load("n: 8\n");
  apply_override(root, "n=");
  try {
    ConfigReader r(root, "cfg.yaml");
    int n = 0;
    r.read("n", &n, 1, 1024);
    ADD_FAILURE() << "--set n= was read as " << n;
  } catch (const ConfigError& err) {
    EXPECT_NE(std::string(err.what()).find("n: expected an integer, got an empty value"), std::string::npos) << err.what();
  }
}

TEST(YamlConfig, OverridesSetNestedKeysAndTheirErrorsAreCaught) {
  YAML::Node root = YAML::Load("n: 8\nsub: {inner: 1}\n");
  apply_override(root, "sub.inner=7");
  apply_override(root, "n=16");
  EXPECT_EQ(root["sub"]["inner"].as<int>(), 7);
  EXPECT_EQ(root["n"].as<int>(), 16);
  EXPECT_THROW(apply_override(root, "novalue"), ConfigError);
  EXPECT_THROW(apply_override(root, "n.deeper=1"), ConfigError);  // n is a value, not a section
}

// A bad value given by --set is reported as that --set, not as the file's: the file may be fine.
TEST(YamlConfig, ErrorsInOverriddenValuesNameTheSetNotTheFile) {
  auto error_after = [](const std::vector<std::string>& sets) -> std::string {
    YAML::Node root = YAML::Load("n: 8\nsub: {inner: 1}\n");
    for (const std::string& s : sets) apply_override(root, s);
    try {
      ConfigReader r(root, "cfg.yaml");
      int n = 0, inner = 0;
      r.read("n", &n, 1, 1024);
      ConfigReader sub = r.child("sub");
      sub.read("inner", &inner, 0, 10);
      sub.finish();
      r.finish();
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(error_after({"n=abc"}), "--set n=abc: n: expected an integer, got 'abc'");
  EXPECT_EQ(error_after({"sub.inner=11"}).rfind("--set sub.inner=11: sub.inner: value 11 is out of range", 0), 0u)
      << error_after({"sub.inner=11"});
  EXPECT_EQ(error_after({"sub.innr=2"}).rfind("--set sub.innr=2: unknown key 'sub.innr'", 0), 0u)
      << error_after({"sub.innr=2"});
  EXPECT_EQ(error_after({"nn=2"}), "--set nn=2: unknown key 'nn' (known here: n, sub)");
  // A whole section given by --set: a bad key inside it names that --set too.
  EXPECT_EQ(error_after({"sub={inner: 1, x: 2}"}).rfind("--set sub={inner: 1, x: 2}: unknown key 'sub.x'", 0), 0u)
      << error_after({"sub={inner: 1, x: 2}"});
  // Keys the --set did not touch still name the file, and good overrides read as before.
  YAML::Node root = YAML::Load("n: 0\n");
  apply_override(root, "sub.inner=4");
  try {
    ConfigReader r(root, "cfg.yaml");
    int n = 0;
    r.read("n", &n, 1, 1024);
    ADD_FAILURE() << "n: 0 was accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("cfg.yaml: n: value 0 is out of range", 0), 0u) << e.what();
  }
  EXPECT_EQ(root["sub"]["inner"].as<int>(), 4);
  EXPECT_EQ(error_after({"n=12", "sub.inner=3"}), "");
}

TEST(YamlConfig, MissingFileAndSyntaxErrorsAreOneLine) {
  try {
    load_yaml_file("/nonexistent/x.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/x.yaml: cannot open"), std::string::npos);
  }
  // A directory opens as an empty stream; it must not pass as an empty (all-defaults) config.
  const std::string dir = ::testing::TempDir();
  try {
    load_yaml_file(dir);
    FAIL() << "a directory was accepted as a config file";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(": is a directory"), std::string::npos);
  }
  // A device would be read forever (/dev/zero) instead of failing.
  try {
    load_yaml_file("/dev/zero");
    FAIL() << "a device was read as a config file";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/zero: is not a regular file"), std::string::npos) << e.what();
  }
  try {
    parse_yaml_text("race:\n  n_env: [1\n", "cfg.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("cfg.yaml:", 0), 0u) << what;  // file and line first
    EXPECT_NE(what.find("YAML syntax error"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace f16race::io
