// `mesocap verify PATH`: checks every data file of a capture session or a
// material package against the size and hash recorded when it was written
// (pipelines/verify.h), names each damaged file, and fails if there is one.
#include <spdlog/spdlog.h>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "pipelines/verify.h"

namespace mesocap {

void RegisterVerifyCommand(CLI::App& app) {
  auto o = std::make_shared<pipelines::VerifyOptions>();
  CLI::App* sub = app.add_subcommand("verify", HelpText("verify"));
  sub->add_option("path", o->path, "capture session or material package folder")->required();
  sub->callback([o] {
    const pipelines::VerifyReport r = pipelines::RunVerify(*o);
    for (const auto& d : r.damaged) spdlog::error("{}: {}", (o->path / d.file).string(), d.problem);
    if (r.version < 2) {
      spdlog::warn("{}: a version {} {} records no checksums: sizes and decoding checked only", o->path.string(),
                   r.version, r.kind);
    }
    if (r.steps_done < r.steps_planned) {
      spdlog::warn("{}: incomplete: {} of {} steps done (finish it with simulate --resume, or capture)",
                   o->path.string(), r.steps_done, r.steps_planned);
    }
    if (r.torn_journal_bytes > 0) {
      spdlog::warn("{}: the journal ends in {} bytes of an interrupted record (dropped when the session resumes)",
                   o->path.string(), r.torn_journal_bytes);
    }
    if (!r.damaged.empty()) {
      throw core::Error(o->path.string() + ": " + std::to_string(r.damaged.size()) + " of " +
                        std::to_string(r.files_checked) + " files of this " + r.kind + " are damaged");
    }
    spdlog::info("{}: {} intact: {} files, {:.1f} MB checked", o->path.string(), r.kind, r.files_checked,
                 r.bytes_checked / 1e6);
  });
}

}  // namespace mesocap
