// Progress of long work, for people and for scripts: on a terminal a bar that
// redraws in place; otherwise (a pipe, a log file, the capture daemon) one JSON
// object per line: {"task": ..., "done": n, "total": n, "elapsed_s": t}.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <string>

namespace mesocap::core {

class Progress {
 public:
  enum class Style { kAuto, kBar, kJsonLines, kSilent };

  // kAuto picks kBar when `out` is a terminal and kJsonLines otherwise, and
  // kSilent under -q (quiet means no progress either). `out` null: where
  // mesocap's messages go (core::MessageStream()).
  Progress(std::string task, std::uint64_t total, Style style = Style::kAuto, std::FILE* out = nullptr);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // Thread-safe. Output is throttled (bar: 10 redraws/s; JSON: one line per
  // second or per 10 % of the work), so calling it per item is cheap.
  void Advance(std::uint64_t n = 1);
  // Prints the final state once; the destructor calls it too.
  void Finish();

  std::uint64_t done() const;
  Style style() const { return style_; }

 private:
  void Print(bool final);

  std::string task_;
  std::uint64_t total_;
  std::uint64_t done_ = 0;
  Style style_;
  std::FILE* out_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_print_;
  std::uint64_t last_printed_done_ = 0;
  bool finished_ = false;
  bool printed_any_ = false;
  mutable std::mutex mutex_;
};

}  // namespace mesocap::core
