// Headless Chromium (Debian's /usr/bin/chromium) driven over the DevTools
// protocol on a pipe (--remote-debugging-pipe: JSON messages ended by a NUL
// byte, commands on fd 3, answers and events on fd 4), so a test can watch
// one page as it changes. Chromium and the processes it starts run in a
// process group of their own (its crash handler, in a session of its own,
// comes to this process as an orphan: this process becomes the subreaper),
// with HOME, TMPDIR and the profile in a temporary folder; closing kills
// them all, reaps them and removes the folder.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "tests/common/no_leftovers.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::testing {

inline constexpr const char* kChromium = "/usr/bin/chromium";

class HeadlessChromium {
 public:
  // Starts Chromium on `url` and attaches to its page. Fails the test (and
  // leaves the object closed) when it does not start in `timeout`.
  explicit HeadlessChromium(const std::string& url, std::chrono::seconds timeout = std::chrono::seconds(60))
      : timeout_(timeout) {
    ::signal(SIGPIPE, SIG_IGN);  // a browser that died must not kill the test on a write
    ::prctl(PR_SET_CHILD_SUBREAPER, 1);
    for (const char* sub : {"home", "tmp", "profile"}) std::filesystem::create_directories(dir_ / sub);
    int commands[2], answers[2];
    if (::pipe2(commands, O_CLOEXEC) != 0 || ::pipe2(answers, O_CLOEXEC) != 0) {
      ADD_FAILURE() << "pipe2 failed";
      return;
    }
    const std::vector<std::string> args = {kChromium,
                                           "--headless",
                                           "--no-sandbox",
                                           "--disable-gpu",
                                           "--disable-quic",
                                           "--no-first-run",
                                           "--disable-background-networking",
                                           "--disable-component-update",
                                           "--disable-sync",
                                           "--disable-dev-shm-usage",
                                           "--remote-debugging-pipe",
                                           "--user-data-dir=" + (dir_ / "profile").string(),
                                           url};
    // Everything the child needs is made before fork: a threaded process's
    // child may only make async-signal-safe calls until exec.
    std::vector<std::string> environment = {"HOME=" + (dir_ / "home").string(), "TMPDIR=" + (dir_ / "tmp").string(),
                                            "XDG_CONFIG_HOME=" + (dir_ / "home").string(),
                                            "XDG_CACHE_HOME=" + (dir_ / "home").string()};
    for (char** e = environ; *e != nullptr; ++e) {
      const std::string entry = *e;
      const std::string name = entry.substr(0, entry.find('='));
      if (name != "HOME" && name != "TMPDIR" && name != "XDG_CONFIG_HOME" && name != "XDG_CACHE_HOME") {
        environment.push_back(entry);
      }
    }
    std::vector<char*> argv, envp;
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    for (const std::string& e : environment) envp.push_back(const_cast<char*>(e.c_str()));
    argv.push_back(nullptr);
    envp.push_back(nullptr);
    const std::string log = (dir_ / "chromium.log").string();
    pid_ = ::fork();
    if (pid_ == 0) {
      ::setpgid(0, 0);
      // Above 4 first, so that moving them to 3 and 4 cannot overwrite one.
      const int in = ::fcntl(commands[0], F_DUPFD, 10), out = ::fcntl(answers[1], F_DUPFD, 10);
      if (in < 0 || out < 0 || ::dup2(in, 3) != 3 || ::dup2(out, 4) != 4) ::_exit(126);
      const int log_fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0600);
      if (log_fd < 0 || ::dup2(log_fd, 1) != 1 || ::dup2(log_fd, 2) != 2) ::_exit(126);
      ::execve(kChromium, argv.data(), envp.data());
      ::_exit(127);
    }
    ::setpgid(pid_, pid_);  // as the child does: no window before exec
    ::close(commands[0]);
    ::close(answers[1]);
    to_browser_ = commands[1];
    from_browser_ = answers[0];
    Attach();
  }

  ~HeadlessChromium() { Close(); }
  HeadlessChromium(const HeadlessChromium&) = delete;
  HeadlessChromium& operator=(const HeadlessChromium&) = delete;

  bool attached() const { return !session_.empty(); }
  // What Chromium wrote on stdout and stderr, for a failure's message.
  std::string log() const {
    std::ifstream in(dir_ / "chromium.log");
    return {std::istreambuf_iterator<char>(in), {}};
  }

  // The value of a JavaScript expression in the page, a promise's once it
  // settles (null on an exception or a closed browser).
  nlohmann::json Evaluate(const std::string& expression) {
    const nlohmann::json answer = Call(
        "Runtime.evaluate", {{"expression", expression}, {"returnByValue", true}, {"awaitPromise", true}}, session_);
    if (!answer.contains("result") || answer["result"].contains("exceptionDetails")) return nullptr;
    return answer["result"]["result"].value("value", nlohmann::json());
  }

  // Evaluates `expression` until `done` holds for its value or `seconds`
  // pass; returns the last value.
  nlohmann::json EvaluateUntil(const std::string& expression, const std::function<bool(const nlohmann::json&)>& done,
                               double seconds = 60) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    nlohmann::json value;
    while (attached()) {
      value = Evaluate(expression);
      if (done(value) || std::chrono::steady_clock::now() > deadline) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return value;
  }

  // Asks Chromium to close, then kills whatever of its process group is
  // left and reaps it all. Idempotent.
  void Close() {
    if (pid_ <= 0) return;
    if (to_browser_ >= 0) {
      Send("Browser.close", nlohmann::json::object(), "");
      ::close(to_browser_);
      to_browser_ = -1;
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (::waitpid(pid_, nullptr, WNOHANG) == 0 && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    // Its children are this process's now (subreaper), still in the group.
    ::kill(-pid_, SIGKILL);
    while (::waitpid(-pid_, nullptr, 0) > 0 || errno == EINTR) {
    }
    EXPECT_EQ(::kill(-pid_, 0), -1) << "a process of Chromium's group " << pid_ << " is left";
    // Its crash handler starts in a session of its own (outside the group;
    // --disable-crashpad-for-testing makes Debian's build crash instead), as
    // an orphan that came to this process.
    for (const int child : ChildProcesses()) {
      std::ifstream comm("/proc/" + std::to_string(child) + "/comm");
      std::string name;
      if (std::getline(comm, name) && name.rfind("chrom", 0) == 0) {
        ::kill(child, SIGKILL);
        ::waitpid(child, nullptr, 0);
      }
    }
    if (from_browser_ >= 0) ::close(from_browser_);
    from_browser_ = -1;
    pid_ = -1;
    session_.clear();
  }

 private:
  void Attach() {
    const nlohmann::json targets = Call("Target.getTargets", nlohmann::json::object(), "");
    if (!targets.contains("result")) {
      ADD_FAILURE() << "Chromium did not answer over the DevTools pipe:\n" << log();
      return;
    }
    for (const nlohmann::json& target : targets["result"].value("targetInfos", nlohmann::json::array())) {
      if (target.value("type", "") != "page") continue;
      const nlohmann::json attached =
          Call("Target.attachToTarget", {{"targetId", target["targetId"]}, {"flatten", true}}, "");
      if (attached.contains("result")) session_ = attached["result"].value("sessionId", "");
      break;
    }
    if (session_.empty()) ADD_FAILURE() << "no page to attach to: " << targets.dump() << "\n" << log();
  }

  int Send(const std::string& method, const nlohmann::json& params, const std::string& session) {
    nlohmann::json message = {{"id", ++last_id_}, {"method", method}, {"params", params}};
    if (!session.empty()) message["sessionId"] = session;
    std::string bytes = message.dump();
    bytes.push_back('\0');
    for (std::size_t sent = 0; sent < bytes.size();) {
      const ssize_t n = ::write(to_browser_, bytes.data() + sent, bytes.size() - sent);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return -1;
      sent += static_cast<std::size_t>(n);
    }
    return last_id_;
  }

  // The answer to one command (events that come first are skipped), or an
  // empty object when the browser is gone or `timeout_` passes.
  nlohmann::json Call(const std::string& method, const nlohmann::json& params, const std::string& session) {
    if (to_browser_ < 0) return nlohmann::json::object();
    const int id = Send(method, params, session);
    if (id < 0) return nlohmann::json::object();
    const auto deadline = std::chrono::steady_clock::now() + timeout_;
    while (true) {
      for (std::size_t end; (end = buffer_.find('\0')) != std::string::npos;) {
        const nlohmann::json message = nlohmann::json::parse(buffer_.substr(0, end), nullptr, false);
        buffer_.erase(0, end + 1);
        if (message.is_object() && message.value("id", -1) == id) return message;
      }
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return nlohmann::json::object();
      pollfd p{from_browser_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) continue;
      char chunk[65536];
      const ssize_t n = ::read(from_browser_, chunk, sizeof chunk);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return nlohmann::json::object();
      buffer_.append(chunk, static_cast<std::size_t>(n));
    }
  }

  std::chrono::seconds timeout_;
  TemporaryDirectory dir_;
  pid_t pid_ = -1;
  int to_browser_ = -1, from_browser_ = -1;
  int last_id_ = 0;
  std::string buffer_;
  std::string session_;
};

}  // namespace mesocap::testing
