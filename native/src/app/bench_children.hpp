// `granular bench` times each run in a child process forked from the settled
// state, so that every thread count (and the machine's ceiling, below) times
// the identical stretch of the same flow, the runs of one round seconds apart:
// a comparison of two thread counts then sees one machine, not two moments of
// a host whose cores change speed by up to a third for seconds at a time
// (docs/speed_accuracy.md, "One settled state per round"). A child holds one simulation, as a run
// does, so its peak resident memory is a run's.
//
// The parent settles on one thread and so has started no OpenMP worker (a
// team of one runs on the calling thread): what the child inherits is one
// thread, which may start its own team.
#pragma once
#include <omp.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "app/thread_placement.hpp"

namespace granular::bench {

// Runs `timed` (returning a JSON object) with `threads` OpenMP threads in
// `copies` children started together, and returns their objects once all have
// finished. A child that fails (its exception, a signal) fails the call, after
// every child has been reaped.
template <class Timed>
std::vector<nlohmann::json> in_children(Timed&& timed, int threads, int copies) {
  struct Child {
    pid_t pid;
    int fd;
  };
  std::vector<Child> kids;
  for (int c = 0; c < copies; ++c) {
    int fds[2];
    if (pipe(fds) != 0) throw std::runtime_error(std::string("bench: pipe: ") + std::strerror(errno));
    std::fflush(nullptr);
    const pid_t pid = fork();
    if (pid < 0) throw std::runtime_error(std::string("bench: fork: ") + std::strerror(errno));
    if (pid == 0) {
      close(fds[0]);
      std::string out;
      int status = 0;
      try {
        omp_set_num_threads(threads);
        const char* placed = place_threads();  // as a run of this many threads places them
        nlohmann::json j = timed();
        j["placement"] = placed;
        out = j.dump();
      } catch (const std::exception& e) {
        out = nlohmann::json{{"error", e.what()}}.dump();
        status = 1;
      }
      for (std::size_t k = 0; k < out.size();) {
        const ssize_t w = write(fds[1], out.data() + k, out.size() - k);
        if (w <= 0) _exit(2);
        k += static_cast<std::size_t>(w);
      }
      _exit(status);  // no destructors, no atexit: the parent's state is the parent's
    }
    close(fds[1]);
    kids.push_back({pid, fds[0]});
  }
  std::vector<nlohmann::json> out;
  std::string failure;
  for (const Child& k : kids) {
    std::string text;
    char buf[4096];
    for (ssize_t r; (r = read(k.fd, buf, sizeof buf)) != 0;) {
      if (r < 0 && errno == EINTR) continue;
      if (r < 0) break;
      text.append(buf, static_cast<std::size_t>(r));
    }
    close(k.fd);
    int status = 0;
    while (waitpid(k.pid, &status, 0) < 0 && errno == EINTR) {
    }
    nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    if (!WIFEXITED(status) || j.is_discarded() || j.contains("error")) {
      if (failure.empty())
        failure = j.is_object() && j.contains("error")
                      ? j["error"].get<std::string>()
                      : (WIFSIGNALED(status) ? "killed by signal " + std::to_string(WTERMSIG(status))
                                             : "exit status " + std::to_string(WEXITSTATUS(status)));
      continue;
    }
    out.push_back(std::move(j));
  }
  if (!failure.empty()) throw std::runtime_error("bench: a timed run failed: " + failure);
  return out;
}

}  // namespace granular::bench
