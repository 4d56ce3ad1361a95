#include "core/error.h"

namespace mesocap::core {

FormatError::FormatError(std::filesystem::path file, std::string field, const std::string& problem)
    : Error(file.string() + ": " + (field.empty() ? std::string() : "field '" + field + "': ") +
            problem),
      file_(std::move(file)),
      field_(std::move(field)) {}

}  // namespace mesocap::core
