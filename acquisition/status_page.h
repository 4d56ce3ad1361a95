// The capture daemon's status page: one self-contained HTML document (its
// CSS and JavaScript inline, nothing fetched from elsewhere), kept as
// acquisition/status_page.html and compiled in by CMake. It reads the
// bearer token from its address's fragment (#token=..., which a browser
// never sends) and polls the control API with it about once a second.
#pragma once

#include <string_view>

namespace mesocap::acquisition {

std::string_view StatusPageHtml();

}  // namespace mesocap::acquisition
