#include "core/version.h"

namespace mesocap::core {

const char* Version() { return MESOCAP_VERSION; }

}  // namespace mesocap::core
