#include "launcher.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <thread>

#include "obm/core/errors.hpp"

extern char** environ;

namespace obm::apps {

namespace {
std::atomic<int> g_forward_signal{0};
void onLauncherSignal(int sig) {
  g_forward_signal = sig;
}
}  // namespace

int freeLoopbackPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) throw IoError(std::string("obm-train --nproc: socket(): ") + std::strerror(errno));
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = 0;
  socklen_t len = sizeof(a);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) {
    const std::string err = std::strerror(errno);
    ::close(fd);
    throw IoError("obm-train --nproc: cannot find a free loopback port: " + err);
  }
  const int port = ntohs(a.sin_port);
  ::close(fd);
  return port;
}

int launchRanks(const std::vector<std::string>& argv, int nproc, const std::string& log_dir,
                double grace_s) {
  if (nproc < 1) throw ConfigError("--nproc must be >= 1");
  std::filesystem::create_directories(log_dir);
  const int port = freeLoopbackPort();
  std::vector<pid_t> pids(static_cast<std::size_t>(nproc), -1);
  // The environment of every rank: ours plus the rendezvous variables.
  std::vector<std::string> base_env;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string kv = *e;
    const auto key = kv.substr(0, kv.find('='));
    if (key != "RANK" && key != "WORLD_SIZE" && key != "MASTER_ADDR" && key != "MASTER_PORT" &&
        key != "LOCAL_RANK")
      base_env.push_back(kv);
  }
  std::fprintf(stderr, "[obm-train] launching %d ranks (127.0.0.1:%d); ranks 1..%d log to %s\n",
               nproc, port, nproc - 1, (log_dir + "/rank_K.log").c_str());
  auto sig_int = std::signal(SIGINT, onLauncherSignal);
  auto sig_term = std::signal(SIGTERM, onLauncherSignal);
  for (int r = 0; r < nproc; ++r) {
    std::vector<std::string> env = base_env;
    env.push_back("RANK=" + std::to_string(r));
    env.push_back("LOCAL_RANK=" + std::to_string(r));
    env.push_back("WORLD_SIZE=" + std::to_string(nproc));
    env.push_back("MASTER_ADDR=127.0.0.1");
    env.push_back("MASTER_PORT=" + std::to_string(port));
    std::vector<char*> cargv, cenv;
    for (const auto& a : argv) cargv.push_back(const_cast<char*>(a.c_str()));
    cargv.push_back(nullptr);
    for (const auto& e : env) cenv.push_back(const_cast<char*>(e.c_str()));
    cenv.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    const std::string log = log_dir + "/rank_" + std::to_string(r) + ".log";
    if (r > 0) {
      posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      posix_spawn_file_actions_adddup2(&fa, 1, 2);
    }
    pid_t pid = -1;
    const int rc = posix_spawn(&pid, argv[0].c_str(), &fa, nullptr, cargv.data(), cenv.data());
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) {
      for (pid_t p : pids)
        if (p > 0) ::kill(p, SIGTERM);
      throw IoError("obm-train --nproc: cannot start rank " + std::to_string(r) + " (" + argv[0] +
                    "): " + std::strerror(rc));
    }
    pids[static_cast<std::size_t>(r)] = pid;
  }
  // Wait for all; forward Ctrl-C / SIGTERM; when one rank fails, stop the others.
  int result = 0, alive = nproc, failed_rank = -1;
  bool forwarded = false;
  auto kill_deadline = std::chrono::steady_clock::time_point::max();
  while (alive > 0) {
    if (g_forward_signal != 0 && !forwarded) {
      for (pid_t p : pids)
        if (p > 0) ::kill(p, g_forward_signal);
      forwarded = true;
    }
    if (std::chrono::steady_clock::now() > kill_deadline) {
      for (pid_t p : pids)
        if (p > 0) ::kill(p, SIGKILL);
      kill_deadline = std::chrono::steady_clock::time_point::max();
    }
    int status = 0;
    const pid_t done = ::waitpid(-1, &status, WNOHANG);
    if (done <= 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      continue;
    }
    for (int r = 0; r < nproc; ++r) {
      if (pids[static_cast<std::size_t>(r)] != done) continue;
      pids[static_cast<std::size_t>(r)] = -1;
      --alive;
      const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      if (code != 0 && result == 0) {
        result = code;
        failed_rank = r;
        if (alive > 0) {
          std::fprintf(stderr,
                       "[obm-train] rank %d exited with code %d; stopping the other ranks\n", r,
                       code);
          for (pid_t p : pids)
            if (p > 0) ::kill(p, SIGTERM);
          kill_deadline = std::chrono::steady_clock::now() +
                          std::chrono::milliseconds(static_cast<long>(grace_s * 1000));
        }
      }
    }
  }
  std::signal(SIGINT, sig_int);
  std::signal(SIGTERM, sig_term);
  if (failed_rank > 0)
    std::fprintf(stderr, "[obm-train] see %s/rank_%d.log\n", log_dir.c_str(), failed_rank);
  return result;
}

}  // namespace obm::apps
