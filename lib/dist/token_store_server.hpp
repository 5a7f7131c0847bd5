#pragma once
// The server of the group's key-value store (what c10d's TCPStore is, which LibTorch 1.13 can
// neither bind to one address nor guard): one thread, poll() over the connections, on the
// address it is given. A connection must first present the group's token (store_wire.hpp);
// one that presents a wrong one, garbage, or nothing within `greeting_timeout` is closed and named
// in one line through `log`, and the server goes on serving the others.
#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <thread>

namespace f16race::dist {

struct StoreServerOptions {
  std::string bind_address = "127.0.0.1";  // numeric, or a name of this host
  int port = 0;                             // 0: a free port (tests)
  std::string token;                        // the group's shared token
  std::string name = "the group's store";   // how the log lines call it
  // A connection that has not presented its token this long after it was accepted is dropped.
  std::chrono::milliseconds greeting_timeout{5000};
  // Connections still to present their token, at most; beyond it the oldest is dropped, so a
  // flood of strangers cannot use up this process's file descriptors.
  std::size_t max_greeting_connections = 64;
  // Receives one line (no newline) per dropped connection; called on the server's thread.
  std::function<void(const std::string&)> log;
};

class TokenStoreServer {
 public:
  // Listens before it returns (so clients may connect at once); throws std::runtime_error naming
  // the address when it cannot.
  explicit TokenStoreServer(StoreServerOptions options);
  ~TokenStoreServer();  // stops the thread and closes every connection
  TokenStoreServer(const TokenStoreServer&) = delete;
  TokenStoreServer& operator=(const TokenStoreServer&) = delete;

  int port() const;                // the port it listens on
  std::string local_name() const;  // "127.0.0.1:29500"

 private:
  class Loop;  // the server's state and its thread's work (token_store_server.cpp)
  std::unique_ptr<Loop> loop_;
  std::thread thread_;
};

}  // namespace f16race::dist
