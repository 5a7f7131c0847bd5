// The group's store alone (lib/dist/token_store*.{hpp,cpp}, group_token, store_wire): the
// semantics the group relies on (blocking get and wait with timeouts, add returning the new
// value, TCPStore's compareSet), and strangers: a wrong token, garbage, silence, a connection that
// closes mid-message, more connections than the server lets wait. Each is dropped and named in
// one line while the members' connections go on being served.
#include <gtest/gtest.h>
#include <sys/socket.h>

#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "dist/group_token.hpp"
#include "dist/store_wire.hpp"
#include "dist/tcp_socket.hpp"
#include "dist/token_store.hpp"
#include "dist/token_store_server.hpp"
#include "io/input_error.hpp"

namespace f16race::dist {
namespace {

using namespace std::chrono_literals;
const std::string kToken = "0123456789abcdef-test-token";

std::vector<std::uint8_t> bytes(const std::string& s) { return {s.begin(), s.end()}; }
std::string text(const std::vector<std::uint8_t>& v) { return {v.begin(), v.end()}; }

// The server's log lines, as the test thread waits for them.
class Lines {
 public:
  std::function<void(const std::string&)> sink() {
    return [this](const std::string& line) {
      std::lock_guard<std::mutex> lock(mutex_);
      lines_.push_back(line);
      changed_.notify_all();
    };
  }
  // Waits up to 5 s for `n` lines; returns all of them.
  std::vector<std::string> at_least(std::size_t n) {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait_for(lock, 5s, [&] { return lines_.size() >= n; });
    return lines_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<std::string> lines_;
};

struct Served {
  Lines lines;
  std::unique_ptr<TokenStoreServer> server;
  explicit Served(std::chrono::milliseconds greeting_timeout = 5000ms, std::size_t max_waiting = 64) {
    StoreServerOptions o;
    o.token = kToken;
    o.greeting_timeout = greeting_timeout;
    o.max_greeting_connections = max_waiting;
    o.log = lines.sink();
    server = std::make_unique<TokenStoreServer>(o);
  }
  c10::intrusive_ptr<TokenStore> client(std::chrono::milliseconds timeout = 2000ms) {
    return c10::make_intrusive<TokenStore>("127.0.0.1", server->port(), kToken, timeout);
  }
  Fd raw() { return connect_tcp("127.0.0.1", server->port(), SteadyClock::now() + 2s); }
};

// Whether the server closed `fd` (within 5 s), reading and discarding anything it sent first.
bool closed_by_server(const Fd& fd) {
  for (;;) {
    try {
      recv_exact(fd.get(), 1, SteadyClock::now() + 5s);
    } catch (const std::runtime_error& e) {
      return std::string(e.what()).find("closed") != std::string::npos ||
             std::string(e.what()).find("reset") != std::string::npos;
    }
  }
}

TEST(TokenStore, SetGetAddCheckDeleteAndCount) {
  Served s;
  auto store = s.client();
  store->set("a", bytes("one"));
  EXPECT_EQ(text(store->get("a")), "one");
  EXPECT_EQ(store->add("n", 3), 3);
  EXPECT_EQ(store->add("n", 2), 5);
  EXPECT_EQ(store->add("n", 0), 5);
  EXPECT_EQ(text(store->get("n")), "5");  // counters are decimal text, as in TCPStore
  EXPECT_TRUE(store->check({"a", "n"}));
  EXPECT_FALSE(store->check({"a", "missing"}));
  EXPECT_EQ(store->getNumKeys(), 2);
  EXPECT_TRUE(store->deleteKey("a"));
  EXPECT_FALSE(store->deleteKey("a"));
  EXPECT_EQ(store->getNumKeys(), 1);
  EXPECT_THROW(store->add("n", INT64_MAX), std::runtime_error);  // overflow: refused, not wrapped
  store->set("t", bytes("text"));
  EXPECT_THROW(store->add("t", 1), std::runtime_error);
  EXPECT_EQ(store->add("n", 1), 6);  // the connection still serves after a refused request
}

TEST(TokenStore, CompareSetFollowsTcpStore) {
  Served s;
  auto store = s.client();
  EXPECT_EQ(text(store->compareSet("k", bytes("x"), bytes("y"))), "x");  // missing, expected given: left alone
  EXPECT_FALSE(store->check({"k"}));
  EXPECT_EQ(text(store->compareSet("k", {}, bytes("v1"))), "v1");  // missing, expected empty: created
  EXPECT_EQ(text(store->compareSet("k", bytes("no"), bytes("v2"))), "v1");
  EXPECT_EQ(text(store->compareSet("k", bytes("v1"), bytes("v2"))), "v2");
}

TEST(TokenStore, GetAndWaitBlockUntilAnotherClientSets) {
  Served s;
  auto reader = s.client(5000ms);
  auto writer = s.client();
  std::thread later([&] {
    std::this_thread::sleep_for(200ms);
    writer->set("late", bytes("here"));
    std::this_thread::sleep_for(100ms);
    writer->add("later", 1);
  });
  const auto t0 = SteadyClock::now();
  EXPECT_EQ(text(reader->get("late")), "here");
  reader->wait({"late", "later"});
  EXPECT_GE(SteadyClock::now() - t0, 250ms);
  later.join();
}

TEST(TokenStore, TimeoutsFailAndLeaveTheConnectionUsable) {
  Served s;
  auto store = s.client(300ms);
  const auto t0 = SteadyClock::now();
  EXPECT_THROW(store->get("never"), std::runtime_error);
  EXPECT_GE(SteadyClock::now() - t0, 290ms);
  EXPECT_THROW(store->wait({"never"}, 100ms), std::runtime_error);
  store->set("after", bytes("ok"));
  EXPECT_EQ(text(store->get("after")), "ok");
}

TEST(TokenStore, ListensOnTheAddressItIsGiven) {
  Served s;
  EXPECT_EQ(s.server->local_name().rfind("127.0.0.1:", 0), 0u) << s.server->local_name();
  StoreServerOptions same_port;
  same_port.port = s.server->port();
  EXPECT_THROW(TokenStoreServer{same_port}, std::runtime_error);  // taken
}

TEST(TokenStore, WrongTokenIsRefusedAndNamed) {
  Served s;
  auto member = s.client();
  member->set("k", bytes("v"));
  EXPECT_THROW(TokenStore("127.0.0.1", s.server->port(), kToken + "x", 2000ms), TokenRefused);
  EXPECT_THROW(TokenStore("127.0.0.1", s.server->port(), "", 2000ms), TokenRefused);
  const auto lines = s.lines.at_least(2);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0].rfind("dropped a connection from 127.0.0.1:", 0), 0u) << lines[0];
  EXPECT_NE(lines[0].find("to the group's store: no valid group token (a wrong token)"), std::string::npos) << lines[0];
  EXPECT_EQ(text(member->get("k")), "v");
}

TEST(TokenStore, StrangersAreDroppedAndTheMembersServed) {
  Served s(400ms);
  auto member = s.client(5000ms);
  Fd garbage = s.raw();
  send_all(garbage.get(), "GET / HTTP/1.1\r\nHost: x\r\n\r\n");
  Fd huge = s.raw();
  send_all(huge.get(), std::string("\xff\xff\xff\x7f", 4));
  Fd silent = s.raw();
  Fd half = s.raw();  // the start of a greeting, then nothing
  send_all(half.get(), wire::Writer().raw(wire::kGreeting).raw("0123").frame().substr(0, 10));
  { Fd quits = s.raw(); }
  EXPECT_TRUE(closed_by_server(garbage));
  EXPECT_TRUE(closed_by_server(huge));
  EXPECT_TRUE(closed_by_server(silent));
  EXPECT_TRUE(closed_by_server(half));
  const auto lines = s.lines.at_least(5);
  ASSERT_EQ(lines.size(), 5u);
  std::string all;
  for (const auto& l : lines) all += l + "\n";
  EXPECT_NE(all.find("(bytes that are not an f16race store greeting)"), std::string::npos) << all;
  EXPECT_NE(all.find("(none presented within 0.4 s)"), std::string::npos) << all;
  EXPECT_NE(all.find("(closed before sending one)"), std::string::npos) << all;
  member->set("still", bytes("served"));
  EXPECT_EQ(text(member->get("still")), "served");
}

TEST(TokenStore, MemberLeavingMidMessageOrMidWaitLeavesTheServerServing) {
  Served s;
  auto member = s.client();
  {
    auto waiter = c10::make_intrusive<TokenStore>("127.0.0.1", s.server->port(), kToken, 100ms);
    EXPECT_THROW(waiter->get("never"), std::runtime_error);
  }
  Fd raw = s.raw();
  send_all(raw.get(), wire::Writer().raw(wire::kGreeting).raw(kToken).frame());
  EXPECT_EQ(recv_exact(raw.get(), 5, SteadyClock::now() + 2s).back(), '\0');  // status ok
  // A parked get, then half of a set, then gone.
  send_all(raw.get(), wire::Writer().u8(static_cast<std::uint8_t>(wire::Op::get)).blob("nope").i64(0).frame());
  send_all(raw.get(), wire::Writer().u8(static_cast<std::uint8_t>(wire::Op::set)).blob("k").blob("v").frame().substr(0, 7));
  raw.reset();
  std::this_thread::sleep_for(100ms);
  member->set("nope", bytes("now"));  // would answer the gone connection's parked get
  EXPECT_EQ(text(member->get("nope")), "now");
  EXPECT_FALSE(member->check({"k"}));
  EXPECT_TRUE(s.lines.at_least(0).empty());  // members leaving are no strangers
}

TEST(TokenStore, AFloodOfSilentConnectionsCannotLockMembersOut) {
  Served s(5000ms, 8);
  std::vector<Fd> flood;
  for (int i = 0; i < 20; ++i) flood.push_back(s.raw());
  auto member = s.client();  // accepted behind 20 silent ones: the oldest make room
  member->set("in", bytes("yes"));
  EXPECT_EQ(text(member->get("in")), "yes");
  const auto lines = s.lines.at_least(12);
  ASSERT_GE(lines.size(), 12u);
  EXPECT_NE(lines[0].find("none yet while 8 connections waited to present one"), std::string::npos) << lines[0];
}

TEST(GroupToken, ComparesWholeTokens) {
  EXPECT_TRUE(tokens_equal("abcdef", "abcdef"));
  EXPECT_FALSE(tokens_equal("abcdef", "abcdeg"));
  EXPECT_FALSE(tokens_equal("abcdef", "abcdefabcdef"));  // a repeat of the token is not the token
  EXPECT_FALSE(tokens_equal("abcdef", "abc"));
  EXPECT_FALSE(tokens_equal("abcdef", ""));
  const std::string a = random_group_token(), b = random_group_token();
  EXPECT_EQ(a.size(), 64u);
  EXPECT_NE(a, b);
}

TEST(GroupToken, ComesFromTheEnvironmentOrAFile) {
  ::unsetenv("F16RACE_GROUP_TOKEN");
  ::unsetenv("F16RACE_GROUP_TOKEN_FILE");
  EXPECT_EQ(group_token_from_environment(), "");
  ::setenv("F16RACE_GROUP_TOKEN", "short", 1);
  EXPECT_THROW(group_token_from_environment(), io::InputError);
  ::setenv("F16RACE_GROUP_TOKEN", kToken.c_str(), 1);
  EXPECT_EQ(group_token_from_environment(), kToken);
  const std::string path = testing::TempDir() + "group_token_test.txt";
  std::ofstream(path) << kToken << "\n";
  ::setenv("F16RACE_GROUP_TOKEN_FILE", path.c_str(), 1);
  EXPECT_THROW(group_token_from_environment(), io::InputError);  // both set
  ::unsetenv("F16RACE_GROUP_TOKEN");
  EXPECT_EQ(group_token_from_environment(), kToken);  // its newline dropped
  ::setenv("F16RACE_GROUP_TOKEN_FILE", (path + ".missing").c_str(), 1);
  EXPECT_THROW(group_token_from_environment(), io::InputError);
  ::unsetenv("F16RACE_GROUP_TOKEN_FILE");
}

}  // namespace
}  // namespace f16race::dist
