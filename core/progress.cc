#include "core/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "core/logging.h"

namespace mesocap::core {
namespace {

constexpr int kBarWidth = 30;

}  // namespace

Progress::Progress(std::string task, std::uint64_t total, Style style, std::FILE* out)
    : task_(std::move(task)), total_(total), style_(style), out_(out != nullptr ? out : MessageStream()) {
  if (style_ == Style::kAuto && !InfoWanted()) style_ = Style::kSilent;
  if (style_ == Style::kAuto) {
    style_ = (out_ != nullptr && ::isatty(::fileno(out_))) ? Style::kBar : Style::kJsonLines;
  }
  start_ = last_print_ = std::chrono::steady_clock::now();
}

Progress::~Progress() { Finish(); }

std::uint64_t Progress::done() const {
  std::lock_guard lock(mutex_);
  return done_;
}

void Progress::Advance(std::uint64_t n) {
  std::lock_guard lock(mutex_);
  if (finished_) return;
  done_ = std::min(total_, done_ + n);
  const auto now = std::chrono::steady_clock::now();
  const double since = std::chrono::duration<double>(now - last_print_).count();
  const bool tenth = total_ > 0 && (done_ - last_printed_done_) * 10 >= total_;
  if ((style_ == Style::kBar && since >= 0.1) || (style_ == Style::kJsonLines && (since >= 1.0 || tenth))) {
    Print(false);
    printed_any_ = true;
    last_print_ = now;
    last_printed_done_ = done_;
  }
}

void Progress::Finish() {
  std::lock_guard lock(mutex_);
  if (finished_) return;
  finished_ = true;
  // A JSON line for this state was already printed by Advance(); a bar still
  // needs its final newline.
  if (style_ == Style::kJsonLines && printed_any_ && last_printed_done_ == done_) return;
  Print(true);
}

void Progress::Print(bool final) {
  if (style_ == Style::kSilent || out_ == nullptr) return;
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  if (style_ == Style::kJsonLines) {
    const nlohmann::json line = {
        {"task", task_}, {"done", done_}, {"total", total_}, {"elapsed_s", std::round(elapsed * 1000) / 1000}};
    std::fprintf(out_, "%s\n", line.dump().c_str());
  } else {
    const double fraction = total_ > 0 ? static_cast<double>(done_) / total_ : 1.0;
    const int filled = static_cast<int>(fraction * kBarWidth);
    std::string bar(filled, '#');
    bar.resize(kBarWidth, '.');
    std::fprintf(out_, "\r%s [%s] %llu/%llu %5.1f%% %.1fs%s", task_.c_str(), bar.c_str(),
                 static_cast<unsigned long long>(done_), static_cast<unsigned long long>(total_), 100.0 * fraction,
                 elapsed, final ? "\n" : "");
  }
  std::fflush(out_);
}

}  // namespace mesocap::core
