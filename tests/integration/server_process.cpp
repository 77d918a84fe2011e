#include "tests/integration/server_process.h"

#include <cstdio>
#include <fcntl.h>
#include <fstream>
#include <signal.h>
#include <sstream>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace touchmend::testing {

TempDir::TempDir() {
  std::string pattern = (std::filesystem::temp_directory_path() / "touchmend-it-XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  path_ = pattern;
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

ServerProcess::ServerProcess(std::filesystem::path data_dir, std::vector<std::string> extra_args)
    : data_dir_(std::move(data_dir)), args_(std::move(extra_args)) {}

ServerProcess::~ServerProcess() {
  if (pid_ > 0) stop(SIGKILL);
}

bool ServerProcess::start() {
  const auto port_file = data_dir_ / "port.txt";
  std::filesystem::create_directories(data_dir_);
  std::filesystem::remove(port_file);
  log_file_ = data_dir_ / "server.log";
  // A restart listens on the same port, so clients can reconnect to the address they know.
  const std::string listen = "127.0.0.1:" + std::to_string(port_);
  std::vector<std::string> argv = {TOUCHMEND_SERVER_PATH,
                                   "--listen",
                                   listen,
                                   "--data-dir",
                                   (data_dir_ / "store").string(),
                                   "--port-file",
                                   port_file.string(),
                                   "--metrics",
                                   "127.0.0.1:0"};
  argv.insert(argv.end(), args_.begin(), args_.end());
  pid_ = ::fork();
  if (pid_ < 0) return false;
  if (pid_ == 0) {
    const int fd = ::open(log_file_.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd >= 0) {
      ::dup2(fd, STDERR_FILENO);
      ::dup2(fd, STDOUT_FILENO);
    }
    std::vector<char*> raw;
    for (auto& a : argv) raw.push_back(a.data());
    raw.push_back(nullptr);
    ::execv(raw[0], raw.data());
    ::_exit(127);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      return false;
    }
    std::ifstream in(port_file);
    unsigned port = 0, metrics = 0;
    if (in >> port >> metrics) {
      port_ = static_cast<std::uint16_t>(port);
      metrics_port_ = static_cast<std::uint16_t>(metrics);
      return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  stop(SIGKILL);
  return false;
}

int ServerProcess::stop(int signal) {
  if (pid_ <= 0) return 0;
  ::kill(pid_, signal);
  int status = 0;
  ::waitpid(pid_, &status, 0);
  pid_ = -1;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return -WTERMSIG(status);
  return -1;
}

std::string ServerProcess::log() const {
  return read_binary_file(log_file_);
}

net::ChannelOptions ServerProcess::options(const std::string& token) const {
  net::ChannelOptions o;
  o.host = "127.0.0.1";
  o.port = port_;
  o.token = token;
  o.connect_timeout = std::chrono::seconds(10);
  return o;
}

std::shared_ptr<net::Channel> ServerProcess::connect(const std::string& token) const {
  net::Status status;
  auto channel = net::Channel::connect(options(token), status);
  if (!channel)
    std::fprintf(stderr, "connect to 127.0.0.1:%u failed: %s\n", port_, status.to_string().c_str());
  return channel;
}

std::string read_binary_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_binary_file(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << bytes;
}

std::filesystem::path shared_data() {
  return TOUCHMEND_SHARED_DATA_DIR;
}

v1::SharpEdgeRequest sharp_edge_push(const std::string& session_id, const std::array<double, 3>& at,
                                     double motion, double step) {
  v1::SharpEdgeRequest request;
  request.set_session_id(session_id);
  auto* sample = request.mutable_push();
  sample->mutable_proxy()->set_x(at[0]);
  sample->mutable_proxy()->set_y(at[1]);
  sample->mutable_proxy()->set_z(at[2]);
  sample->mutable_previous()->set_x(at[0]);
  sample->mutable_previous()->set_y(at[1] - motion);
  sample->mutable_previous()->set_z(at[2]);
  sample->set_face(0xFFFFFFFFu);  // the patch face nearest the proxy
  sample->set_step(step);
  return request;
}

}  // namespace touchmend::testing
