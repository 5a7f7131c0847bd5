// `f16race launch`'s group on this host: free port pairs outside the ephemeral range, each
// rank's environment, and the first failing rank's status (ranks here are /bin/sh).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "dist/local_launch.hpp"

namespace f16race::dist {
namespace {

LocalGroup shell_group(int nproc, const std::string& script) {
  LocalGroup g;
  g.nproc = nproc;
  g.port = 23456;
  g.timeout_s = 5.0;
  g.executable = "/bin/sh";
  g.argv = {"sh", "-c", script};
  return g;
}

TEST(LocalLaunch, FreePortPairOutsideTheEphemeralRange) {
  int lo = 32768, hi = 60999;
  if (std::FILE* f = std::fopen("/proc/sys/net/ipv4/ip_local_port_range", "r")) {
    if (std::fscanf(f, "%d %d", &lo, &hi) != 2) lo = 32768, hi = 60999;
    std::fclose(f);
  }
  for (int k = 0; k < 5; ++k) {
    const int port = free_port_pair();
    EXPECT_GE(port, 1024);
    EXPECT_LE(port, 65533);
    if (lo - 2 >= 10000 || hi + 1 <= 65533) {
      EXPECT_TRUE(port + 1 < lo || port > hi) << port;
    }
  }
}

TEST(LocalLaunch, EveryRankGetsTheGroupsEnvironment) {
  const std::string check =
      "test \"$WORLD_SIZE\" = 3 && test \"$LOCAL_RANK\" = \"$RANK\" && test \"$MASTER_ADDR\" = 127.0.0.1 && "
      "test \"$MASTER_PORT\" = 23456 && test \"$F16RACE_DIST_TIMEOUT\" = 5 && test \"$F16RACE_BIND_ADDR\" = 127.0.0.1 && "
      "test ${#F16RACE_GROUP_TOKEN} -gt 16 && test -z \"$F16RACE_GROUP_TOKEN_FILE\" || exit 9";
  EXPECT_EQ(run_local_group(shell_group(3, check)), 0);
}

TEST(LocalLaunch, TheFailingRanksStatus) {
  EXPECT_EQ(run_local_group(shell_group(3, "test \"$RANK\" = 2 && exit 7; exit 0")), 7);
  EXPECT_EQ(run_local_group(shell_group(2, "test \"$RANK\" = 0 && kill -9 $$; exit 0")), 128 + 9);
}

}  // namespace
}  // namespace f16race::dist
