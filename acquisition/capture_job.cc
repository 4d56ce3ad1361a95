#include "acquisition/capture_job.h"

#include <array>
#include <nlohmann/json.hpp>
#include <vector>

#include "acquisition/capture_plan.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_field_reader.h"

namespace mesocap::acquisition {
namespace {

constexpr std::string_view kFormat = "mesocap.capture_job";
constexpr int kVersion = 1;

}  // namespace

bool IsFinished(JobState state) {
  return state == JobState::kDone || state == JobState::kFailed || state == JobState::kCancelled;
}

std::optional<double> CaptureJob::EtaSeconds() const {
  if (steps_done == 0 || steps_total == 0 || running_s <= 0) return std::nullopt;
  return running_s / static_cast<double>(steps_done) * static_cast<double>(steps_total - steps_done);
}

nlohmann::json ToJson(const CaptureJob& job) {
  nlohmann::json j{{"format", kFormat},
                   {"version", kVersion},
                   {"id", job.id},
                   {"plan", job.plan_kind},
                   {"state", ToString(job.state)},
                   {"submitted_at", job.submitted_at},
                   {"steps_done", job.steps_done},
                   {"steps_total", job.steps_total},
                   {"frames", job.frames},
                   {"dropped_frames", job.dropped_frames},
                   {"retries", job.retries},
                   {"faults", job.faults},
                   {"running_s", job.running_s},
                   {"pause_reason", job.pause_reason},
                   {"paused_by_fault", job.paused_by_fault},
                   {"operator_prompt", job.operator_prompt},
                   {"error", job.error},
                   {"pause_requested", job.pause_requested},
                   {"cancel_requested", job.cancel_requested},
                   {"started", job.started}};
  if (const std::optional<double> eta = job.EtaSeconds()) {
    j["eta_s"] = *eta;
  } else {
    j["eta_s"] = nullptr;
  }
  return j;
}

CaptureJob ReadCaptureJob(const std::filesystem::path& file) {
  const nlohmann::json document = core::ReadJsonFile(file, 1 << 20);
  const core::JsonFieldReader r(document, file);
  r.ExpectFormat(kFormat, kVersion);
  r.RejectUnknownMembers({"format",
                          "version",
                          "id",
                          "plan",
                          "state",
                          "submitted_at",
                          "steps_done",
                          "steps_total",
                          "frames",
                          "dropped_frames",
                          "retries",
                          "faults",
                          "running_s",
                          "pause_reason",
                          "paused_by_fault",
                          "operator_prompt",
                          "error",
                          "pause_requested",
                          "cancel_requested",
                          "started",
                          "eta_s"});
  CaptureJob job;
  job.id = r.String("id");
  if (!IsJobId(job.id)) r.Fail("id", "expected \"job-\" and at least six digits, got " + core::Quoted(job.id));
  if (file.stem() != job.id) r.Fail("id", "expected " + core::Quoted(file.stem().string()) + " (the file's name)");
  job.plan_kind = r.Choice("plan", kPlanKinds);
  job.state = *core::EnumFromString<JobState>(r.Choice("state", core::EnumStrings<JobState>()));
  job.submitted_at = r.String("submitted_at");
  constexpr std::int64_t kMax = std::int64_t{1} << 53;
  job.steps_done = static_cast<std::uint64_t>(r.Integer("steps_done", 0, kMax));
  job.steps_total = static_cast<std::uint64_t>(r.Integer("steps_total", 0, kMax));
  if (job.steps_done > job.steps_total) r.Fail("steps_done", "expected at most steps_total");
  job.frames = static_cast<std::uint64_t>(r.Integer("frames", 0, kMax));
  job.dropped_frames = static_cast<std::uint64_t>(r.Integer("dropped_frames", 0, kMax));
  job.retries = static_cast<std::uint64_t>(r.Integer("retries", 0, kMax));
  job.faults = static_cast<std::uint64_t>(r.Integer("faults", 0, kMax));
  job.running_s = r.Number("running_s", 0, 1e12);
  job.pause_reason = r.String("pause_reason");
  job.paused_by_fault = r.Boolean("paused_by_fault");
  job.operator_prompt = r.StringOr("operator_prompt", "");  // absent in records of daemons before prompts
  job.error = r.String("error");
  job.pause_requested = r.Boolean("pause_requested");
  job.cancel_requested = r.Boolean("cancel_requested");
  // Absent in records of daemons before the check: such a job may have run.
  job.started = r.Has("started") ? r.Boolean("started") : true;
  return job;
}

void WriteCaptureJob(const std::filesystem::path& file, const CaptureJob& job) {
  core::WriteJsonFileAtomically(file, ToJson(job));
}

bool IsJobId(std::string_view id) {
  // At most 19 digits: every such number fits in 64 bits.
  if (id.size() < 10 || id.size() > 23 || id.substr(0, 4) != "job-") return false;
  for (const char c : id.substr(4)) {
    if (c < '0' || c > '9') return false;
  }
  return id.size() == 10 || id[4] != '0';
}

std::string JobId(std::uint64_t number) {
  const std::string digits = std::to_string(number);
  return "job-" + std::string(digits.size() < 6 ? 6 - digits.size() : 0, '0') + digits;
}

std::uint64_t JobNumber(std::string_view id) { return std::stoull(std::string(id.substr(4))); }

}  // namespace mesocap::acquisition
