// The spin bound f16race sets for libgomp: only where the user chose nothing, and once.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "io/openmp_waits.hpp"

namespace f16race::io {
namespace {

std::string spin_env_or_unset(const char* name) {
  const char* v = std::getenv(name);
  return v == nullptr ? "(unset)" : v;
}

// ctest gives every case OMP_WAIT_POLICY=PASSIVE; each case puts back what it found.
class OpenmpWaits : public ::testing::Test {
 protected:
  void SetUp() override { policy_ = spin_env_or_unset("OMP_WAIT_POLICY"); }
  void TearDown() override {
    unsetenv("GOMP_SPINCOUNT");
    if (policy_ == "(unset)") unsetenv("OMP_WAIT_POLICY");
    else setenv("OMP_WAIT_POLICY", policy_.c_str(), 1);
  }
  std::string policy_;
};

TEST_F(OpenmpWaits, BoundsTheSpinsOnceWhereTheUserChoseNothing) {
  unsetenv("OMP_WAIT_POLICY");
  unsetenv("GOMP_SPINCOUNT");
  EXPECT_TRUE(bound_openmp_spins());
  EXPECT_EQ(spin_env_or_unset("GOMP_SPINCOUNT"), kOpenmpSpinCount);
  EXPECT_FALSE(bound_openmp_spins());  // a second call changes nothing: the process runs itself again once
}

TEST_F(OpenmpWaits, KeepsTheUsersChoice) {
  setenv("OMP_WAIT_POLICY", "ACTIVE", 1);
  unsetenv("GOMP_SPINCOUNT");
  EXPECT_FALSE(bound_openmp_spins());
  EXPECT_EQ(spin_env_or_unset("GOMP_SPINCOUNT"), "(unset)");
  unsetenv("OMP_WAIT_POLICY");
  setenv("GOMP_SPINCOUNT", "infinite", 1);
  EXPECT_FALSE(bound_openmp_spins());
  EXPECT_EQ(spin_env_or_unset("GOMP_SPINCOUNT"), "infinite");
}

}  // namespace
}  // namespace f16race::io
