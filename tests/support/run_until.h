#pragma once
// Test and benchmark support: drive an io_context until a condition holds (event-driven: no sleeping).
#include <chrono>
#include <filesystem>
#include <functional>
#include <string>

#include <unistd.h>

#include <boost/asio/io_context.hpp>

namespace dca::test {

/// Runs `io` until `pred` holds (true) or `timeout` passes (false), one handler at a time.
inline bool run_until(boost::asio::io_context& io, const std::function<bool()>& pred,
                      std::chrono::milliseconds timeout = std::chrono::seconds(5)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    io.restart();
    io.run_one_for(std::chrono::milliseconds(10));
  }
  return true;
}

/// A Unix-socket path in the temp directory, unique to this process and `tag`: dca-<prefix>-<pid>-<tag>.sock.
inline std::string temp_socket(const std::string& prefix, const std::string& tag) {
  const auto name = "dca-" + prefix + "-" + std::to_string(::getpid()) + "-" + tag + ".sock";
  return (std::filesystem::temp_directory_path() / name).string();
}

}  // namespace dca::test
