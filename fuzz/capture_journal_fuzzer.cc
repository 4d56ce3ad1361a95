// Drives formats::ReadCaptureJournal with the input as a session's
// journal.jsonl, checked against the plan of fuzz::TinySessionManifest.
#include "formats/capture_journal.h"
#include "fuzz/fuzz_input.h"
#include "fuzz/tiny_instances.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mesocap;
  static const formats::SessionManifest manifest = fuzz::TinySessionManifest();
  const std::filesystem::path file = fuzz::ScratchDir() / formats::kSessionJournalName;
  fuzz::WriteFileBytes(file, fuzz::Bytes(data, size));
  return fuzz::ReadRejectingOnlyWithError([&] { formats::ReadCaptureJournal(file, &manifest); });
}
