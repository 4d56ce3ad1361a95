// The flags shared by the commands that factor a BTF (compress, process
// btf): the budget (--rank, --max-error or --max-bytes) and the
// representation (--layout, --color; "auto" chooses), bound to a
// btf::BtfCompressionOptions.
#pragma once

#include <CLI/CLI.hpp>

#include "btf/btf_compression.h"

namespace mesocap {

void AddCompressionOptions(CLI::App* command, btf::BtfCompressionOptions* options);

}  // namespace mesocap
