#include "core/version.h"

namespace mesocap {

const char* Version() { return MESOCAP_VERSION; }

}  // namespace mesocap
