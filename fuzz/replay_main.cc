// Replays inputs through every fuzzer's entry point, as libFuzzer would run
// one input: `fuzz_replay CORPUS...`, where each CORPUS folder holds a
// folder per fuzzer (seed_corpus/<name>, regressions/<name>) of input files.
// A missing folder is skipped. Each fuzzer runs in a child process of its
// own, as it does under libFuzzer (its scratch folder and static state are
// its own). An input that crashes, trips a sanitizer or throws anything but
// core::Error (which the entry points absorb) fails the run, its path on
// stderr.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#define MESOCAP_FUZZER(name) extern "C" int name##_TestOneInput(const std::uint8_t* data, std::size_t size);
#include "fuzzer_entry_points.inc"
#undef MESOCAP_FUZZER

namespace {

namespace fs = std::filesystem;

struct EntryPoint {
  const char* name;
  int (*run)(const std::uint8_t*, std::size_t);
};

#define MESOCAP_FUZZER(name) {#name, &name##_TestOneInput},
const EntryPoint kEntryPoints[] = {
#include "fuzzer_entry_points.inc"
};
#undef MESOCAP_FUZZER

// Runs every input of `entry` found under the corpora; 0 when none failed.
int Replay(const EntryPoint& entry, const std::vector<fs::path>& corpora) {
  std::size_t inputs = 0;
  for (const fs::path& corpus : corpora) {
    const fs::path dir = corpus / entry.name;
    if (!fs::is_directory(dir)) continue;
    std::vector<fs::path> files;
    for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
      if (e.is_regular_file()) files.push_back(e.path());
    }
    std::sort(files.begin(), files.end());
    for (const fs::path& file : files) {
      std::ifstream in(file, std::ios::binary);
      const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      if (in.bad()) {
        std::fprintf(stderr, "fuzz_replay: cannot read %s\n", file.c_str());
        return 1;
      }
      try {
        entry.run(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
      } catch (const std::exception& e) {
        std::fprintf(stderr, "fuzz_replay: %s: %s threw: %s\n", entry.name, file.c_str(), e.what());
        return 1;
      }
      ++inputs;
    }
  }
  std::printf("fuzz_replay: %s: %zu inputs\n", entry.name, inputs);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // `fuzz_replay --fuzzer NAME CORPUS...`: one fuzzer, in this process (a
  // child the run below started: a fresh process, not a fork, since
  // libraries loaded here keep threads that a forked child would wait for).
  if (argc >= 3 && std::string(argv[1]) == "--fuzzer") {
    const std::vector<fs::path> corpora(argv + 3, argv + argc);
    for (const EntryPoint& entry : kEntryPoints) {
      if (entry.name == std::string(argv[2])) return Replay(entry, corpora);
    }
    std::fprintf(stderr, "fuzz_replay: no fuzzer %s\n", argv[2]);
    return 2;
  }
  if (argc < 2) {
    std::fprintf(stderr, "usage: fuzz_replay CORPUS...\n");
    return 2;
  }
  int failed = 0;
  for (const EntryPoint& entry : kEntryPoints) {
    std::vector<char*> args{argv[0], const_cast<char*>("--fuzzer"), const_cast<char*>(entry.name)};
    args.insert(args.end(), argv + 1, argv + argc);
    args.push_back(nullptr);
    std::fflush(stdout);
    const pid_t child = fork();
    if (child < 0) {
      std::perror("fuzz_replay: fork");
      return 1;
    }
    if (child == 0) {
      execv("/proc/self/exe", args.data());
      std::perror("fuzz_replay: exec");
      _exit(127);
    }
    int status = 0;
    if (waitpid(child, &status, 0) != child || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      std::fprintf(stderr, "fuzz_replay: %s failed\n", entry.name);
      ++failed;
    }
  }
  return failed == 0 ? 0 : 1;
}
