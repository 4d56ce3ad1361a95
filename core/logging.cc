#include "core/logging.h"

#include <fcntl.h>
#include <spdlog/sinks/ansicolor_sink.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/common_interface_defs.h>
#endif

#include <cstdint>

namespace mesocap::core {
namespace {

std::FILE* message_stream = nullptr;

// Points fd 2 at /dev/null and returns a stream on a copy of the old fd 2;
// null (nothing changed) when that cannot be done.
std::FILE* SetLibraryOutputAside() {
  const int copy = ::fcntl(2, F_DUPFD_CLOEXEC, 3);
  if (copy < 0) return nullptr;
  std::FILE* stream = ::fdopen(copy, "w");
  const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
  if (stream == nullptr || null < 0 || ::dup2(null, 2) < 0) {
    if (stream != nullptr) std::fclose(stream);
    if (null >= 0) ::close(null);
    return nullptr;
  }
  ::close(null);
  std::setvbuf(stream, nullptr, _IOLBF, 0);
#if defined(__SANITIZE_ADDRESS__)
  // A sanitizer's report is mesocap's own business: keep it visible.
  __sanitizer_set_report_fd(reinterpret_cast<void*>(static_cast<std::intptr_t>(copy)));
#endif
  return stream;
}

}  // namespace

std::FILE* MessageStream() { return message_stream != nullptr ? message_stream : stderr; }

bool InfoWanted() { return spdlog::should_log(spdlog::level::info); }

void ConfigureLogging(int verbosity) {
  std::fflush(stderr);
  if (verbosity < 1 && message_stream == nullptr) message_stream = SetLibraryOutputAside();
  auto sink = std::make_shared<spdlog::sinks::ansicolor_sink<spdlog::details::console_mutex>>(
      MessageStream(), spdlog::color_mode::automatic);
  auto logger = std::make_shared<spdlog::logger>("mesocap", std::move(sink));
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
  if (verbosity < 0) {
    spdlog::set_level(spdlog::level::warn);
  } else if (verbosity == 0) {
    spdlog::set_level(spdlog::level::info);
  } else if (verbosity == 1) {
    spdlog::set_level(spdlog::level::debug);
  } else {
    spdlog::set_level(spdlog::level::trace);
  }
}

}  // namespace mesocap::core
