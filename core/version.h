// The version of this build, recorded as provenance.
#pragma once

namespace mesocap::core {

// The project version from CMakeLists.txt ("0.1.0"); recorded in every
// capture session and material package as provenance.
const char* Version();

}  // namespace mesocap::core
