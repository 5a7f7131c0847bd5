#pragma once
// A client of rank 0's TokenStoreServer, usable wherever c10d wants a Store (ProcessGroupGloo's
// rendezvous among them): it connects, presents the group's token, then sends one request at a
// time and waits for its reply. get() and wait() block until their keys are set or the timeout;
// add() returns the new value. Safe to share between threads (one request at a time).
#include <torch/csrc/distributed/c10d/Store.hpp>

#include <chrono>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "dist/tcp_socket.hpp"

namespace f16race::dist {

// The server refused this client's token: the ranks were given different tokens.
struct TokenRefused : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class TokenStore : public c10d::Store {
 public:
  // Connects to host:port, trying again until `timeout` while nothing listens there yet, and
  // presents `token`. Throws TokenRefused when the server refuses it, std::runtime_error when no
  // store answers. `timeout` is also the default wait of get() and wait().
  TokenStore(const std::string& host, int port, const std::string& token, std::chrono::milliseconds timeout);
  ~TokenStore() override;

  void set(const std::string& key, const std::vector<std::uint8_t>& value) override;
  std::vector<std::uint8_t> compareSet(const std::string& key, const std::vector<std::uint8_t>& expected,
                                       const std::vector<std::uint8_t>& desired) override;
  std::vector<std::uint8_t> get(const std::string& key) override;
  std::int64_t add(const std::string& key, std::int64_t value) override;
  bool deleteKey(const std::string& key) override;
  bool check(const std::vector<std::string>& keys) override;
  std::int64_t getNumKeys() override;
  void wait(const std::vector<std::string>& keys) override;
  void wait(const std::vector<std::string>& keys, const std::chrono::milliseconds& timeout) override;

  const std::string& where() const { return where_; }  // "host:port"

 private:
  // Sends one request frame and returns its reply's fields after the status byte. `server_wait`:
  // how long the server may hold the request (get, wait); the reply may take that long.
  std::string call(const std::string& frame, std::chrono::milliseconds server_wait, const std::string& what);
  std::mutex mutex_;
  Fd fd_;  // closed after a failed call: the next one reports the connection as lost
  std::string where_;
};

}  // namespace f16race::dist
