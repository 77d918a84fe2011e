#pragma once

//! \file server_process.h
//! \brief Starts a real touchmend-server process on loopback for integration tests (a free
//! port from --listen 127.0.0.1:0 and --port-file), and stops or kills it.

#include <array>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <sys/types.h>
#include <vector>

#include "client/net/channel.h"
#include "client/net/repair_client.h"

namespace touchmend::testing {

//! A fresh directory under /tmp, removed at destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

class ServerProcess {
 public:
  ServerProcess(std::filesystem::path data_dir, std::vector<std::string> extra_args = {});
  ~ServerProcess();
  //! Starts the server and waits (up to 20 s) until it listens. False on failure.
  bool start();
  //! Sends \p signal and waits for the process to end; returns its exit status (or -signal).
  int stop(int signal);
  bool running() const { return pid_ > 0; }
  pid_t pid() const { return pid_; }
  std::uint16_t port() const { return port_; }
  std::uint16_t metrics_port() const { return metrics_port_; }
  const std::filesystem::path& data_dir() const { return data_dir_; }
  std::string log() const;

  net::ChannelOptions options(const std::string& token = "") const;
  std::shared_ptr<net::Channel> connect(const std::string& token = "") const;

 private:
  std::filesystem::path data_dir_;
  std::vector<std::string> args_;
  pid_t pid_ = -1;
  std::uint16_t port_ = 0;
  std::uint16_t metrics_port_ = 0;
  std::filesystem::path log_file_;
};

std::string read_binary_file(const std::filesystem::path& path);
void write_binary_file(const std::filesystem::path& path, const std::string& bytes);
//! The shared data directory (../shared/data).
std::filesystem::path shared_data();

//! A SharpEdge push tool sample at \p at that came from \p motion back along -y (the edge's
//! direction in the cube tests), the touched face left to the server, \p step per sample.
v1::SharpEdgeRequest sharp_edge_push(const std::string& session_id, const std::array<double, 3>& at,
                                     double motion, double step);

}  // namespace touchmend::testing
