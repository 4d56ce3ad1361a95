// The BTF evaluation (`mesocap eval btf`): the error of a material package's
// BTF (factored if it holds one, else full) against a true full BTF
// (`mesocap groundtruth`) on the same texture grid and direction sets,
// overall and by view polar angle; captured, interpolated and unresolved
// pairs apart when the estimate's error report records which are which
// (`process btf` does); and of its ambient term when both have one.
#pragma once

#include <nlohmann/json.hpp>

#include <filesystem>

#include "core/error.h"

namespace mesocap::pipelines {

struct EvaluateBtfOptions {
  std::filesystem::path truth;     // material package with the true full BTF
  std::filesystem::path estimate;  // material package to evaluate

  core::CheckResult Check() const;
};

// The figures as btf::ToJson gives them (`overall`, `by_polar_angle`, `rank`,
// `peak`, `captured`, `interpolated`, `unresolved`, `captured_within_60deg`),
// plus `form` ("factored" or "full") and, when both packages hold one,
// `ambient`. Reads one view of each package at a time. Throws Error
// ("eval btf: ...") when the truth holds no full BTF, the estimate no BTF, or
// the two differ in grid or directions.
nlohmann::json EvaluateBtf(const EvaluateBtfOptions& options);

}  // namespace mesocap::pipelines
